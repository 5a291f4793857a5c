#version 460
// Confidence-based occlusion classification (paper 000, Sect. 5, Fig. 10), hierarchical:
// push.mode 0 tests every node, push.mode 1 every meshlet (a meshlet of a node in O is O).
// The box test: the axis-aligned box is projected (8 corners, unjittered projection); its pixel
// rectangle selects the pyramid level where it covers at most kNodeExtent^2 texels (nodes: few,
// so a fine level whose texels reach little beyond the box, which the max-depth test would
// otherwise take in -- e.g. the far depths seen through a neighbouring pore) or kMeshletExtent^2
// (meshlets: many, one pass over all of them). The depth test fails
// (occluded) when the box's nearest view depth is >= the largest d_cull over the covered texels
// (the pyramid stores max depth, so this is conservative); the aggregated confidence is the
// mean C_cull over the covered texels (Eq. 23 averages, so this is the covered area's mean).
// Boxes reaching behind the near plane pass. Boxes entirely outside the image are O (frustum
// culled: they cannot contribute to any pixel, and their particles are not on any pixel ray).
// Classes only move upward (mds_classify_occlusion keeps max(previous, new)). A meshlet that
// reaches O subtracts its voxel contributions from the density volume (Sect. 4.4); with
// kCullNodeDensity (streaming) a node reaching O subtracts the whole node instead, resident or not.
// Empty slots of the streaming pool (particle_count 0) are skipped and not counted.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "culling_math.glsl"
#include "cull_bindings.h"

layout(local_size_x = 64) in;
const int kNodeExtent = 16;    // texels per side at most: <= 256 reads per node
const int kMeshletExtent = 4;  // <= 16 reads per meshlet

// Returns MDS_CULL_CLASS_* for the box without the "upward" rule (-1: outside the image).
int classify_box(vec3 bmin, vec3 bmax, int max_extent) {
  float W = cull.viewport.x, H = cull.viewport.y;
  vec2 lo = vec2(3.0e38), hi = vec2(-3.0e38);
  float znear = 3.0e38;
  for (int i = 0; i < 8; ++i) {
    vec3 c = vec3((i & 1) != 0 ? bmax.x : bmin.x, (i & 2) != 0 ? bmax.y : bmin.y,
                  (i & 4) != 0 ? bmax.z : bmin.z);
    vec4 v = cull.view * vec4(c, 1.0);
    float z = -v.z;
    if (z <= cull.camera.z) return MDS_CULL_CLASS_P;  // reaches the near plane: visible
    znear = min(znear, z);
    vec4 clip = cull.proj * v;
    vec2 ndc = clip.xy / clip.w;
    vec2 px = (ndc * 0.5 + 0.5) * vec2(W, H);
    lo = min(lo, px);
    hi = max(hi, px);
  }
  if (hi.x <= 0.0 || hi.y <= 0.0 || lo.x >= W || lo.y >= H) return -1;
  ivec2 p0 = clamp(ivec2(floor(lo)), ivec2(0), ivec2(W, H) - 1);
  ivec2 p1 = clamp(ivec2(ceil(hi)) - 1, ivec2(0), ivec2(W, H) - 1);
  p1 = max(p1, p0);
  int extent = max(p1.x - p0.x, p1.y - p0.y) + 1;
  uint level = 0u;
  while (extent > max_extent && level + 1u < cull.pyramid.x) {
    level++;
    extent = max((p1.x >> level) - (p0.x >> level), (p1.y >> level) - (p0.y >> level)) + 1;
  }
  uvec2 ls = cull_level_size(level);
  uint lo_off = cull_level_offset(level);
  ivec2 t0 = p0 >> int(level), t1 = p1 >> int(level);
  float dmax = 0.0, csum = 0.0, n = 0.0;
  for (int y = t0.y; y <= t1.y; ++y)
    for (int x = t0.x; x <= t1.x; ++x) {
      vec2 dc = pyramid[lo_off + uint(y) * ls.x + uint(x)];
      dmax = max(dmax, dc.x);
      csum += dc.y;
      n += 1.0;
    }
  bool failed = znear >= dmax;
  return mds_classify_occlusion(MDS_CULL_CLASS_P, failed, csum / n, cull.thresholds.x,
                                cull.thresholds.y);
}

void subtract_voxels(uint i) {  // Sect. 4.4: remove meshlet/node i's particles from the volume
  for (uint r = meshlet_voxel_first[i]; r < meshlet_voxel_first[i + 1u]; ++r)
    atomicAdd(volume_counts[voxel_refs[r].x], -int(voxel_refs[r].y));
  counters.volume_dirty = 1u;
}

void main() {
  uint i = gl_GlobalInvocationID.x;
  bool node_density = (cull.params.w & kCullNodeDensity) != 0u;
  if (push.mode == 0u) {
    if (i >= cull.counts.y) return;
    uint prev = node_class[i];
    uint now = prev;
    if (prev != uint(MDS_CULL_CLASS_O)) {
      int c = classify_box(nodes[i].aabb_min, nodes[i].aabb_max, kNodeExtent);
      now = c < 0 ? uint(MDS_CULL_CLASS_O) : max(prev, uint(c));
      node_class[i] = now;
    }
    if (now != prev) {
      atomicAdd(counters.node_changed, 1u);
      if (now == uint(MDS_CULL_CLASS_O) && node_density) subtract_voxels(i);
    }
    atomicAdd(counters.node_class_count[now], 1u);
    return;
  }
  if (i >= cull.counts.x) return;
  GpuMeshlet m = meshlets[i];
  if (m.particle_count == 0u) return;  // empty slot of the streaming pool
  uint prev = meshlet_class[i];
  uint now = prev;
  if (prev != uint(MDS_CULL_CLASS_O)) {
    if (node_class[m.node] == uint(MDS_CULL_CLASS_O)) {
      now = uint(MDS_CULL_CLASS_O);
    } else {
      int c = classify_box(m.aabb_min, m.aabb_max, kMeshletExtent);
      now = c < 0 ? uint(MDS_CULL_CLASS_O) : max(prev, uint(c));  // classes only move upward
    }
  }
  if (now != prev) {
    meshlet_class[i] = now;
    atomicAdd(counters.changed, 1u);
    if (now == uint(MDS_CULL_CLASS_O)) {
      if (!node_density) subtract_voxels(i);
      atomicAdd(counters.newly_occluded, 1u);
    }
  }
  atomicAdd(counters.class_count[now], 1u);
}
