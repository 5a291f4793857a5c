#version 460
// Confidence-based occlusion classification (paper 000, Sect. 5, Fig. 10), hierarchical:
// push.mode 0 tests every node, push.mode 1 every meshlet (a meshlet of a node in O is O).
// The box test: the axis-aligned box is projected (8 corners, unjittered projection); its pixel
// rectangle selects the pyramid level where it covers at most kNodeExtent^2 (nodes) or
// kMeshletExtent^2 (meshlets) texels. The paper rasterizes the box and depth-tests its fragments
// against d_cull; here, per texel of the rectangle, the box's conservative entry depth on the
// texel's centre ray (mds_ray_box_entry on the box grown by the texel's half diagonal, see
// culling_math.h): texels the box does not reach are skipped -- so the far depths seen through
// a neighbouring pore, at the corners of the rectangle, no longer keep a box visible -- and the
// depth test fails (occluded) when the entry depth is >= d_cull on every covered texel (the
// pyramid stores max depth, so coarser levels stay conservative); the aggregated confidence is
// the mean C_cull over the covered texels (Eq. 23 averages: the covered area's mean). The first
// texel where the box lies in front ends the test: the box is P whatever the confidence.
// Boxes reaching behind the near plane pass unless their part in front of it projects outside
// the image. Boxes entirely outside the image are O (frustum
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
// Texels per side at most: kNodeExtentInMemory (32, <= 1024 ray tests per node) or, streaming,
// kNodeExtentStreaming (128) -- cull_loop.h.
layout(constant_id = 0) const int kNodeExtent = 32;
const int kMeshletExtent = 32;  // <= 1024 ray tests per meshlet
// Measured at 1920x1080 (1M, ablation v1 / porous v0): 16 makes the meshlet classification 3x
// cheaper (119 -> 41, 79 -> 28 ms) but keeps 5 % more meshlets (kept / visible 1.08 -> 1.13,
// 1.22 -> 1.28), which every frame after convergence pays; 32 stays.

// Returns MDS_CULL_CLASS_* for the box without the "upward" rule (-1: outside the image).
int classify_box(vec3 bmin, vec3 bmax, int max_extent) {
  float W = cull.viewport.x, H = cull.viewport.y;
  vec2 lo = vec2(3.0e38), hi = vec2(-3.0e38);
  float znear = 3.0e38, zfar = 0.0;
  vec3 vlo = vec3(3.0e38), vhi = vec3(-3.0e38);  // view-space bounds of the corners
  for (int i = 0; i < 8; ++i) {
    vec3 c = vec3((i & 1) != 0 ? bmax.x : bmin.x, (i & 2) != 0 ? bmax.y : bmin.y,
                  (i & 4) != 0 ? bmax.z : bmin.z);
    vec4 v = cull.view * vec4(c, 1.0);
    vlo = min(vlo, v.xyz);
    vhi = max(vhi, v.xyz);
    float z = -v.z;
    znear = min(znear, z);
    zfar = max(zfar, z);
    vec4 clip = cull.proj * v;
    vec2 ndc = clip.xy / clip.w;
    vec2 px = (ndc * 0.5 + 0.5) * vec2(W, H);
    lo = min(lo, px);
    hi = max(hi, px);
  }
  if (znear <= cull.camera.z) {
    // The box reaches the near plane: no depth test (visible), unless its part in front of the
    // plane -- inside the view-space box of its corners cut at the plane -- projects outside
    // the image (a box beside the eye, as when the camera is inside the data).
    if (zfar <= cull.camera.z) return -1;  // entirely behind the near plane
    lo = vec2(3.0e38);
    hi = vec2(-3.0e38);
    for (int i = 0; i < 8; ++i) {
      vec4 v = vec4((i & 1) != 0 ? vhi.x : vlo.x, (i & 2) != 0 ? vhi.y : vlo.y,
                    -((i & 4) != 0 ? zfar : cull.camera.z), 1.0);
      vec4 clip = cull.proj * v;
      vec2 px = (clip.xy / clip.w * 0.5 + 0.5) * vec2(W, H);
      lo = min(lo, px);
      hi = max(hi, px);
    }
    if (hi.x <= 0.0 || hi.y <= 0.0 || lo.x >= W || lo.y >= H) return -1;
    return MDS_CULL_CLASS_P;
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
  // Per covered texel, the box's conservative entry depth on the texel's centre ray (the box
  // grown by the texel's half diagonal at the box's far side, culling_math.h ray_box_entry):
  // texels of the rectangle the box does not reach take no part in the test.
  bool ortho = (cull.params.w & kCullOrtho) != 0u;
  float texel_px = float(1u << level);
  float grow = 1.001 * mds_texel_half_diagonal(texel_px, zfar, !ortho, cull.camera.x, cull.camera.y);
  vec3 eye = (cull.inv_view * vec4(0.0, 0.0, 0.0, 1.0)).xyz;
  float csum = 0.0, n = 0.0;
  for (int y = t0.y; y <= t1.y; ++y)
    for (int x = t0.x; x <= t1.x; ++x) {
      vec2 ndc = (vec2(x, y) + 0.5) * texel_px * cull.viewport.zw * 2.0 - 1.0;
      vec3 o = eye, dir;
      if (ortho) {
        o = (cull.inv_view * vec4(ndc.x / cull.proj[0][0], ndc.y / cull.proj[1][1], 0.0, 1.0)).xyz;
        dir = mat3(cull.inv_view) * vec3(0.0, 0.0, -1.0);
      } else {
        dir = mat3(cull.inv_view) * vec3(ndc.x / cull.proj[0][0], ndc.y / cull.proj[1][1], -1.0);
      }
      float t_entry = mds_ray_box_entry(o.x, o.y, o.z, dir.x, dir.y, dir.z, bmin.x, bmin.y, bmin.z,
                                        bmax.x, bmax.y, bmax.z, grow, cull.camera.z);
      if (!(t_entry < float(MDS_CULL_DEPTH_EMPTY))) continue;  // the box does not reach this texel
      vec2 dc = pyramid[lo_off + uint(y) * ls.x + uint(x)];
      // In front of d_cull on one texel: the depth test passes, the box is P whatever the
      // confidence (mds_classify_occlusion), so the other texels need no test.
      if (!(t_entry >= dc.x)) return MDS_CULL_CLASS_P;
      csum += dc.y;
      n += 1.0;
    }
  if (n == 0.0) return MDS_CULL_CLASS_P;  // (not expected: the box projects into the image)
  return mds_classify_occlusion(MDS_CULL_CLASS_P, true, csum / n, cull.thresholds.x,
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
