#version 460
// Occluder selection (paper 000, Sect. 5.2): a budget of meshlets per sampling pass, drawn from
// class P first, then from L when P holds fewer than the budget. Randomised per pass so
// that no candidate starves: every candidate gets a fresh random key (hash of meshlet id,
// sampling pass, seed) and is selected when key < budget / |class| -- an unbiased random subset of
// expected size min(budget, |P|) from P (and the rest of the budget from L), the same
// distribution as taking the first `budget` entries of a random permutation, without a sort.
// |P| and |L| are the counts of the previous classification (counters.class_count).
// Selected meshlets are appended to the occluder list (DrawListHeader + ids, set 0's draw list),
// which the sampling pass draws with vkCmdDrawIndexedIndirect.
#extension GL_GOOGLE_include_directive : require
#define MDS_DRAW_LIST_WRITABLE
#include "bindings.h"
#include "culling_math.glsl"
#include "cull_bindings.h"
#include "dispatch_rows.h"

layout(local_size_x = 64) in;

void main() {
  uint m = mds_flat_id();
  if (m >= cull.counts.x) return;
  uint cls = meshlet_class[m];
  if (cls != uint(MDS_CULL_CLASS_P) && cls != uint(MDS_CULL_CLASS_L)) return;
  if (meshlets[m].particle_count == 0u) return;  // empty slot of the streaming pool
  // push.mode: the budget's divisor, > 1 for the probe of a sampling-route comparison
  // (cull_loop.h kSampleRouteProbeShare); 0 and 1: the whole budget.
  float budget = float(cull.params.z) / float(max(push.mode, 1u));
  float nP = float(counters.class_count[MDS_CULL_CLASS_P]);
  float nL = float(counters.class_count[MDS_CULL_CLASS_L]);
  float prob;
  if (cls == uint(MDS_CULL_CLASS_P)) prob = nP > 0.0 ? budget / nP : 0.0;
  else prob = (budget > nP && nL > 0.0) ? (budget - nP) / nL : 0.0;
  float u = cull_uniform01(m, push.pass, cull.counts.w ^ 0x5e1ec7u);
  if (u > prob) return;
  uint slot = atomicAdd(draw_header.instance_count, 1u);
  draw_ids[slot] = m;
  atomicAdd(counters.selected, 1u);
}
