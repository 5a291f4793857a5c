// GLSL-only: descriptor set 1 of the culling passes (cull_shared.h, kCull*), plus helpers shared
// by several culling shaders (random numbers, pyramid level geometry, pixel rays).
#ifndef MDS_CULL_BINDINGS_H
#define MDS_CULL_BINDINGS_H
#ifndef __cplusplus

#include "cull_shared.h"
#include "gpu_types.h"

layout(std140, set = 1, binding = kCullUniforms) uniform CullBlock { CullUniforms cull; };
layout(std430, set = 1, binding = kCullHistogram) buffer HistBlock { float hist_counts[]; };
layout(std430, set = 1, binding = kCullHistRange) buffer HistRangeBlock { vec2 hist_range[]; };
layout(std430, set = 1, binding = kCullPixelState) buffer StateBlock { vec4 pixel_state[]; };
layout(std430, set = 1, binding = kCullPyramid) buffer PyramidBlock { vec2 pyramid[]; };
layout(std430, set = 1, binding = kCullVolume) buffer VolumeBlock { int volume_counts[]; };
layout(std430, set = 1, binding = kCullMeshletVoxels) readonly buffer MeshletVoxelBlock { uint meshlet_voxel_first[]; };
layout(std430, set = 1, binding = kCullVoxelRefs) readonly buffer VoxelRefBlock { uvec2 voxel_refs[]; };
layout(std430, set = 1, binding = kCullMeshletClass) buffer MeshletClassBlock { uint meshlet_class[]; };
layout(std430, set = 1, binding = kCullNodeClass) buffer NodeClassBlock { uint node_class[]; };
layout(std430, set = 1, binding = kCullSampledPixels) buffer SampledPixelsBlock {
  CoveredPixelsHeader sampled_head;
  uint sampled_pixels[];
};
layout(std430, set = 1, binding = kCullCounters) coherent buffer CounterBlock { CullCounters counters; };

layout(push_constant) uniform PushBlock { CullPush push; };

uint cull_width() { return uint(cull.viewport.x); }
uint cull_height() { return uint(cull.viewport.y); }

// PCG hash (Jarzynski & Olano 2020).
uint cull_hash(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
// Uniform in (0, 1]: P = 0 never accepts, P = 1 always does (docs/culling-math.md).
float cull_uniform01(uint a, uint b, uint c) {
  uint h = cull_hash(a ^ cull_hash(b ^ cull_hash(c)));
  return (float(h >> 8) + 1.0) / 16777216.0;
}

// Pyramid level l: size ceil(W / 2^l) x ceil(H / 2^l); levels stored one after another.
uvec2 cull_level_size(uint l) {
  uint w = cull_width(), h = cull_height();
  for (uint i = 0u; i < l; ++i) { w = (w + 1u) / 2u; h = (h + 1u) / 2u; }
  return uvec2(w, h);
}
uint cull_level_offset(uint l) {
  uint w = cull_width(), h = cull_height(), off = 0u;
  for (uint i = 0u; i < l; ++i) { off += w * h; w = (w + 1u) / 2u; h = (h + 1u) / 2u; }
  return off;
}

// D(d_min, d) from the cumulative histogram of a pixel (hist_counts[base + i] = D(d_min, d_i+1),
// Eq. 10 with linear interpolation inside a bin, as mds_hist_front on the per-bin counts): two
// loads instead of a loop over the bins. Needs culling_math.glsl (mds_hist_coord) included first.
float cull_hist_front(uint base, int bins, float d_min, float d_max, float d) {
  if (bins <= 0) return 0.0;
  float u = mds_hist_coord(d, d_min, d_max, bins);
  int i = int(floor(u));
  if (i >= bins) return hist_counts[base + uint(bins - 1)];
  float lo = i > 0 ? hist_counts[base + uint(i - 1)] : 0.0;
  return lo + (hist_counts[base + uint(i)] - lo) * (u - float(i));
}

#endif
#endif  // MDS_CULL_BINDINGS_H
