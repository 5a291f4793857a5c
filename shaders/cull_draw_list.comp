#version 460
// Draw list of the potentially visible set (paper 000, Sect. 3.5): every meshlet not in class O.
// Replaces draw_list_all.comp when culling is on; same list format (DrawListHeader + ids).
#extension GL_GOOGLE_include_directive : require
#define MDS_DRAW_LIST_WRITABLE
#include "bindings.h"
#include "dispatch_rows.h"
#include "culling_math.glsl"
#include "cull_bindings.h"

layout(local_size_x = 64) in;

void main() {
  uint m = mds_flat_id();
  if (m >= cull.counts.x) return;
  if (meshlet_class[m] == uint(MDS_CULL_CLASS_O)) return;
  if (meshlets[m].particle_count == 0u) return;  // empty slot of the streaming pool
  uint slot = atomicAdd(draw_header.instance_count, 1u);
  draw_ids[slot] = m;
}
