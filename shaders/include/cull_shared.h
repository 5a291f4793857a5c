// Structs and bindings shared between the C++ culling loop (src/render/culling/cull_loop.*) and
// its shaders (shaders/cull_*.comp, cull_sample.*): the GPU side of the probabilistic occlusion
// culling of Ibrahim et al. 2021 (paper 000). Same layout rules as gpu_types.h (std140 uniform
// block of mat4/vec4/uvec4 only; std430 storage records of 4-byte scalars).
//
// The culling passes use two descriptor sets:
//   set 0: the renderer's scene layout (bindings.h: frame, nodes, meshlets, particles, types,
//          draw list, radii). The culling loop owns two instances of it: one whose "draw list" is
//          the occluder list (the sampling pass draws it indirectly) and one whose "draw list" is
//          the renderer's draw list (the compaction pass writes the potentially visible set).
//   set 1: the culling state below (kCull*).
#ifndef MDS_CULL_SHARED_H
#define MDS_CULL_SHARED_H

#include "shared_prelude.h"
#ifdef __cplusplus
namespace mds::gpu {
#endif

// Set 1 bindings.
MDS_CONST(uint, kCullUniforms, 0);     // uniform CullUniforms
MDS_CONST(uint, kCullHistogram, 1);    // float[W*H*bins]: cumulative D(d_min, d_i+1) per pixel and bin (Eq. 9-10)
MDS_CONST(uint, kCullHistRange, 2);    // vec2[W*H]: (d_min, d_max) per pixel; d_max <= d_min: empty
MDS_CONST(uint, kCullPixelState, 3);   // vec4[2*W*H]: (d, C, k, -), (d_cull, C_cull, k_cull, -)
MDS_CONST(uint, kCullPyramid, 4);      // vec2[]: (d, C) of every pyramid level, level 0 first
MDS_CONST(uint, kCullVolume, 5);       // int[dims]: particle counts of the density volume
MDS_CONST(uint, kCullMeshletVoxels, 6);// uint[meshlets+1] (or nodes+1, kCullNodeDensity): first VoxelRef (CSR)
MDS_CONST(uint, kCullVoxelRefs, 7);    // uvec2[]: (voxel, count) per meshlet or node (Sect. 4.4 updates)
MDS_CONST(uint, kCullMeshletClass, 8); // uint[meshlets]: MDS_CULL_CLASS_*
MDS_CONST(uint, kCullNodeClass, 9);    // uint[nodes]
MDS_CONST(uint, kCullCounters, 10);    // CullCounters
MDS_CONST(uint, kCullSampleImage, 11); // rg32f storage image: (view depth, alpha_s) of the sample
MDS_CONST(uint, kCullNormalCdf, 12);   // float[256]: the normal CDF table of supplement A (1 KiB)
MDS_CONST(uint, kCullSampleBuffer, 13); // uint64[W * H] (read as uvec2): the compute route's samples, depth bits << 32 | alpha bits
MDS_CONST(uint, kCullSampledPixels, 14); // CoveredPixelsHeader (gpu_types.h) + uint[W * H]: the pixels with a sample of this pass (x | y << 16; compute route)

// CullUniforms.params.w flags
MDS_CONST(uint, kCullOrtho, 1u);
// Density updates per node (streaming, issue 4: "O updates subtract whole nodes whether resident
// or not"): voxel CSR (kCullMeshletVoxels/kCullVoxelRefs) is indexed by node and applied when a
// node reaches O; without it the CSR is per meshlet and applied when a meshlet reaches O.
MDS_CONST(uint, kCullNodeDensity, 2u);
// Algorithm 1 with the depth extension (confidence_buffer.h extend_accumulation), set with
// exact or automatic coverage (CullSettings::coverage).
MDS_CONST(uint, kCullExtendDepth, 4u);

// Push constant of the culling passes. mode: cull_classify 0 nodes, 1 meshlets; cull_pyramid the
// destination level; cull_histogram 1 = recompute unconditionally; cull_select the occluder
// budget's divisor (0, 1: the whole budget). pass: index of the occlusion
// sampling pass within the view (random numbers of cull_select and cull_update). jitter: the
// sampling pass's sub-pixel offset in NDC (cull_sample.vert/.frag; frame.proj is unjittered).
MDS_STRUCT(CullPush) {
  uint mode;
  uint pass;
  float jitter_x;
  float jitter_y;
};

// Per-view constants (std140).
MDS_STRUCT(CullUniforms) {
  mat4 view;         // world (relative to the scene origin) -> view space (camera looks along -z)
  mat4 inv_view;
  mat4 proj;         // unjittered projection (classification and histogram rays)
  vec4 viewport;     // W, H, 1/W, 1/H
  vec4 camera;       // focal length in pixels (perspective), world area of a pixel (ortho), near, far
  vec4 grid_origin;  // density volume box min (relative to the scene origin), w: 0
  vec4 grid_cell;    // cell size xyz, w: 1 / cell volume
  uvec4 grid_dims;   // cells x, y, z; w: histogram bins (1..64)
  vec4 thresholds;   // C_occ, C_medium, R (smallest particle radius, world: the pixel footprint's growth), -
  uvec4 params;      // acceptance mode, N_budget, occluder budget (meshlets per sampling pass), flags
  uvec4 counts;      // meshlet count, node count, iteration (classification), random seed
  uvec4 pyramid;     // number of levels; histogram stride s (pixels per block side), blocks per row, per column
};

// Counters written by the passes; read back by the host after every iteration.
// class_count / changed / volume_dirty / newly_occluded are reset before each classification;
// the selection of the next iteration reads class_count of the previous one.
MDS_STRUCT(CullCounters) {
  uint class_count[4];   // meshlets per class P, L, M, O after the last classification
  uint changed;          // meshlets whose class changed in the last classification
  uint volume_dirty;     // 1 when meshlets reached O (the density volume was updated)
  uint newly_occluded;   // meshlets that reached O in the last classification
  uint selected;         // occluders selected in the last sampling pass
  uint node_class_count[4];
  uint node_changed;     // nodes whose class changed in the last classification
  uint sampled;          // pixels with a sample in the last sampling pass whose update ran over the list
  uint pad[2];
};

#ifdef __cplusplus
static_assert(sizeof(CullPush) == 16);
static_assert(sizeof(CullUniforms) == 3 * 64 + 9 * 16);
static_assert(offsetof(CullUniforms, viewport) == 192);
static_assert(offsetof(CullUniforms, pyramid) == 320);
static_assert(sizeof(CullCounters) == 64);
static_assert(offsetof(CullCounters, changed) == 16);
static_assert(offsetof(CullCounters, node_class_count) == 32);
static_assert(offsetof(CullCounters, node_changed) == 48);
}  // namespace mds::gpu
#undef MDS_STRUCT
#undef MDS_CONST
#endif

#endif  // MDS_CULL_SHARED_H
