// Structs shared between C++ and GLSL: the single definition of every GPU buffer record.
// C++ includes this header (types in namespace mds::gpu, glm types for vectors) and checks
// sizes/offsets with static_assert; GLSL includes it via GL_GOOGLE_include_directive.
// Layout rules used here (std430 for storage buffers, std140 for the uniform block): only
// vec4/uvec4/mat4 and `vec3 followed by one 4-byte scalar`, explicit padding to 16 bytes,
// so the C++ (alignas(16)) and GLSL layouts coincide.
#ifndef MDS_GPU_TYPES_H
#define MDS_GPU_TYPES_H

#include "shared_prelude.h"
#ifdef __cplusplus
namespace mds::gpu {
#endif

// Descriptor bindings of the renderer's single descriptor set (set 0).
MDS_CONST(uint, kBindFrame, 0);       // uniform FrameUniforms
MDS_CONST(uint, kBindNodes, 1);       // GpuNode[]
MDS_CONST(uint, kBindMeshlets, 2);    // GpuMeshlet[]
MDS_CONST(uint, kBindParticles, 3);   // uvec2[] = uint16 x, y, z, type per particle
MDS_CONST(uint, kBindTypes, 4);       // GpuType[]
MDS_CONST(uint, kBindDrawList, 5);    // DrawListHeader + uint meshlet_ids[]
MDS_CONST(uint, kBindRadii, 6);       // uint[] = two uint16 radius_q per uint (optional)
MDS_CONST(uint, kBindColorImage, 7);  // rgba32f storage image: the pass's colour target
MDS_CONST(uint, kBindAccumImage, 8);  // rgba32f storage image: the accumulation where kBindAccumBuffer does not fit
MDS_CONST(uint, kBindSprites, 9);     // GpuSprite[]: per-particle glyph records of the chunk of the list being drawn
MDS_CONST(uint, kBindSpriteDraw, 10); // SpriteDrawHeader + uint quad_ids[] (sprites drawn as quads)
MDS_CONST(uint, kBindVisibility, 11); // uint64[W * H]: nearest depth bits << 32 | GpuSprite.vis_id (visibility route)
MDS_CONST(uint, kBindAccumBuffer, 12);  // vec4[W * H]: the accumulation, 16 B/pixel (accumulation.h)
MDS_CONST(uint, kBindOcclusionPyramid, 13);  // vec2[]: the culling loop's confidence pyramid (particle_occlusion.h)
MDS_CONST(uint, kBindCoveredPixels, 14);  // CoveredPixelsHeader + uint pixel[W * H]: the visibility buffer's covered pixels
MDS_CONST(uint, kBindProperty, 15);   // uint[] = two uint16 property_q per uint (optional; store kFlagProperty)
MDS_CONST(uint, kBindColor, 16);      // uint[] = RGBA8 per particle, R in bits 0..7 (optional; store kFlagColor)

// GpuSprite.flags
MDS_CONST(uint, kSpriteHidden, 0x100u);  // nothing to draw (behind the near plane, radius 0)
MDS_CONST(uint, kSpriteQuad, 0x200u);    // drawn as a quad (point path: too large or centre off screen)
MDS_CONST(uint, kSpriteSmall, 0x400u);   // rasterized in compute into the visibility buffer

// Long 1D dispatches (one invocation per meshlet, node, list entry or occluder particle) run in
// rows of kDispatchRow workgroups: (min(g, kDispatchRow), ceil(g / kDispatchRow), 1), so that
// 64 x 65535 workgroups fit the 65535 per dimension Vulkan guarantees (maxComputeWorkGroupCount,
// maxTaskWorkGroupCount): 268 M invocations of 64 instead of 4.2 M, i.e. 4.2 M meshlets, which
// a GPU's pool passes at about 67 M particles. Shaders take their index from
// include/dispatch_rows.h (mds_flat_id); the host records them with vk::dispatch_rows.
MDS_CONST(uint, kDispatchRow, 64u);

// Mesh sprite path (sphere.task / sphere.mesh, where VK_EXT_mesh_shader exists).
MDS_CONST(uint, kMeshTaskMeshlets, 64u);  // draw-list entries per task workgroup (= sprite_args' dispatch_x unit)
MDS_CONST(uint, kMeshParticles, 32u);     // particles per mesh workgroup: 128 vertices, 64 triangles (<= 256 each on every vendor)
MDS_CONST(uint, kMeshChunksMax, 8u);      // mesh workgroups per meshlet: ceil(255 / 32); task payload 64 * 8 * 4 B = 2 KiB

// FrameUniforms.flags
MDS_CONST(uint, kFrameOrtho, 1u);
MDS_CONST(uint, kFramePerParticleRadius, 2u);
MDS_CONST(uint, kFrameExactCoverage, 8u);  // occlusion samples: alpha_s by exact clipping (CullSettings::coverage exact or automatic)
MDS_CONST(uint, kFrameMixedCoverage, 16u);  // with kFrameExactCoverage: exact only below kMixedExactBelowPx (Coverage::automatic)
MDS_CONST(uint, kFrameTimingOnly, 4u);  // accumulate adds 0 x colour: full cost, the image keeps its spp samples
MDS_CONST(uint, kFrameColorMap, 32u);  // colour by coordinate: the colormap of color_plane (particle_color.h), not the type's
// With kFrameColorMap: colour by the per-particle property instead, t = color_plane.x * q + color_plane.w for its
// quantized value q (GpuSprite.flags bits 16..31, read from kBindProperty by sprite_make.h).
MDS_CONST(uint, kFrameColorProperty, 64u);
// The particles' own colours (--color-by color; store kFlagColor): GpuSprite.color, read from
// kBindColor by sprite_make.h, sRGB, instead of the type's colour.
MDS_CONST(uint, kFrameColorParticle, 128u);
// FrameUniforms::colormap: the samples of the colormap of --colormap (render/colormap_table.h),
// 65 x 16 B = 1040 B of the uniform block.
MDS_CONST(uint, kColormapSamples, 65u);

// Per-frame constants (std140 uniform block).
MDS_STRUCT(FrameUniforms) {
  mat4 view;          // world (relative to the scene origin) -> view space, camera looks along -z
  mat4 proj;          // view -> clip (Vulkan: y down, depth 0..1), including the sub-pixel jitter
  mat4 inv_proj;      // clip -> view
  vec4 viewport;      // width, height, 1/width, 1/height
  vec4 radius_range;  // radius_min, radius_max - radius_min (per-particle radii), near, far
  uvec4 counts;       // meshlet_count, max_meshlet_particles, flags, sample index
  vec4 occlusion;     // particle occlusion test (particle_occlusion.h): C_occ, C_medium, pyramid levels (0: off), 0
  vec4 color_plane;   // with kFrameColorMap: colormap coordinate t = dot(xyz, view-space centre) + w (render/colormap.h);
                      // with kFrameColorProperty t = x * property_q + w
  vec4 ao;            // ambient occlusion (shading/ambient_occlusion.h): radius (world = view units),
                      // strength (0: off), 0, 0; the visibility resolve applies it
  vec4 cell[5];       // the simulation cell's edges (render/cell_lines.h; cell_lines.vert): origin relative to
                      // the scene origin (w 1: drawn), vectors a, b, c, then linear rgb and the width in pixels
  vec4 colormap[kColormapSamples];  // with kFrameColorMap: sRGB at t = k / (kColormapSamples - 1), w 0
                                    // (render::colormap_srgb interpolates as particle_color.h)
};

// GpuNode::flags. Left out: the slices (--slice) keep none of the node's particles (its box lies
// outside them, or reading it kept nothing). The node classification skips it
// (MDS_CULL_NODE_LEFT_OUT); the streaming cache never reads it (again).
MDS_CONST(uint, kGpuNodeLeftOut, 1u);

// One store node: quantization frame relative to the scene origin (float is enough there).
MDS_STRUCT(GpuNode) {
  vec3 origin;          // center_min - scene origin
  uint first_particle;  // index of the node's first particle in the particle buffer
  vec3 step;            // (center_max - center_min) / 65535
  uint particle_count;
  vec3 aabb_min;        // centre bounds -/+ max_radius, relative to the scene origin
  float max_radius;
  vec3 aabb_max;
  uint first_meshlet;
  uint occupancy_lo;    // sub-node occupancy of [aabb_min, aabb_max] (src/culling/node_occupancy.h):
  uint occupancy_hi;    //   bit c of the uint64 lo | hi << 32 = cell c of 4^3 holds part of a particle
  uint flags;           // kGpuNode* bits
  uint pad1;
  uvec4 occupancy_fine[4];  // 8^3 cells, 64 B: byte c (of 64, little-endian in the uints) = the 2^3
                            //   sub-cells of coarse cell c (node_occupancy.h FineOccupancy); all 0 = unknown
};

// One meshlet: a run of particles of one node, with bounds computed at load from decoded positions.
// Its particles are at most two runs of the particle buffer (the streaming pool stores nodes in
// fixed-size pages, so a meshlet may continue on the node's next page): local index l < split is
// at first_particle + l, the others at second_particle + (l - split) (mds_meshlet_particle).
// In memory split == particle_count. particle_count 0 marks an empty slot of the streaming pool.
MDS_STRUCT(GpuMeshlet) {
  vec3 aabb_min;        // sphere bounds (centres -/+ radius), relative to the scene origin
  uint node;
  vec3 aabb_max;
  uint first_particle;  // global index in the particle buffer of local particle 0
  uint particle_count;  // 1..255; 0: empty slot (streaming pool)
  uint split;           // particles in the first run (== particle_count unless split over two pages)
  uint second_particle; // global index of local particle `split`
  uint pad0;
};

// Per-type appearance.
MDS_STRUCT(GpuType) {
  vec4 color;           // linear RGB, a = 1
  float radius;
  uint pad0;
  uint pad1;
  uint pad2;
};

// Head of a draw list buffer: then meshlet ids. A list builder (compute) resets the header and
// appends ids with atomicAdd(instance_count, 1): instance_count is the list length. The draw
// pass turns the list into sprites (sprite_args.comp, sphere_prepass.comp) and draws those;
// the remaining fields keep the VkDrawIndexedIndirectCommand layout for one-instance-per-
// meshlet consumers (index_count = 6 * max_meshlet_particles).
MDS_STRUCT(DrawListHeader) {
  uint index_count;     // 6 * max_meshlet_particles (two triangles per particle)
  uint instance_count;  // number of meshlets in the list (atomic counter)
  uint first_index;
  int vertex_offset;
  uint first_instance;
  // The compute occlusion sampling pass (cull_sample.comp) dispatches itself indirectly from
  // here: a VkDispatchIndirectCommand (workgroups x, y, z) written after the selection.
  uint dispatch_x;
  uint dispatch_y;
  uint dispatch_z;
};

// One particle's glyph, computed once per pass by the sprite pre-pass (sphere_prepass.comp) so
// that the vertex stages only load: screen rectangle, view-space sphere and billboard depth.
// vis_id names the particle in the visibility buffer: its record index where a frame draws its
// list in one chunk; with several chunks (the records are overwritten chunk by chunk) the
// particle's frame-wide id, draw-list entry x max_meshlet_particles + local index, from which
// the resolve rebuilds the winner's sphere (sprite_make.h mds_vis_id_sphere).
MDS_STRUCT(GpuSprite) {
  vec4 rect;           // NDC x_lo, y_lo, x_hi, y_hi, incl. the half-pixel margin
  vec4 center_radius;  // view space centre, radius
  float zndc;          // billboard depth (the sphere's nearest view distance)
  uint flags;          // bits 0..7: type; kSpriteHidden, kSpriteQuad, kSpriteSmall; bits 16..31: property_q
                       // with kFrameColorProperty (else 0)
  uint vis_id;
  uint color;          // with kFrameColorParticle: the particle's RGBA8 (sRGB, R in bits 0..7), else 0
};
MDS_CONST(uint, kVisEmpty, 0xffffffffu);  // the visibility buffer's id of a pixel no sphere covers
MDS_CONST(uint, kVisCell, 0xfffffffeu);   // ... of a pixel the simulation cell's edges cover (cell_lines.frag); particle ids stay below

// Indirect commands of the sprite draws, derived from a draw list (sprite_args.comp) and
// filled by the pre-pass: two VkDrawIndirectCommand (points: one vertex per sprite; quads: six
// vertices per sprite) and the pre-pass's VkDispatchIndirectCommand (one thread per list entry).
// capacity (sprites the buffers hold) and chunk_meshlets are written once by the host. After the
// header: quad_ids [capacity], then (visibility route) the small sprites' ids [capacity] and the
// compute rasterization's VkDispatchIndirectCommand (raster_*: one thread per small sprite).
// Chunks: the sprite records hold `capacity` sprites, not one per particle slot, so a draw list
// is turned into sprites and drawn chunk_meshlets entries at a time (capacity / max meshlet
// size; one chunk where the records hold every slot). Each run of sprite_args.comp starts the
// next chunk at chunk_next (the host zeroes it before a frame's first chunk) and resets the
// per-chunk counters; occluded, offscreen, listed and small_total add up over the frame.
MDS_STRUCT(SpriteDrawHeader) {
  uint point_vertex_count;  // sprites written (atomic counter)
  uint point_instance_count;
  uint point_first_vertex;
  uint point_first_instance;
  uint quad_vertex_count;   // 6 * quads (atomic counter)
  uint quad_instance_count;
  uint quad_first_vertex;
  uint quad_first_instance;
  uint dispatch_x;
  uint dispatch_y;
  uint dispatch_z;
  uint capacity;
  uint occluded;            // sprites of the list hidden by the particle occlusion test (atomic counter)
  uint small_count;         // small sprites listed for the compute rasterization (atomic counter)
  uint raster_x;            // ceil(small_count / 64), counted up by the pre-pass
  uint raster_y;
  uint raster_z;
  uint offscreen;           // sprites of the list with nothing to draw: behind the near plane, off screen, beyond the far plane (atomic counter)
  uint chunk_meshlets;      // draw-list entries per chunk (host)
  uint chunk_next;          // first entry of the next chunk (host: 0 before the first; sprite_args)
  uint chunk_first;         // first entry of the current chunk (sprite_args)
  uint chunk_count;         // entries of the current chunk (sprite_args)
  uint listed;              // sprites of the frame's list, all chunks (atomic counter)
  uint small_total;         // small sprites of the frame, all chunks (atomic counter)
};

// The covered pixels of one frame's visibility buffer, listed by visibility_compact.comp so that
// visibility_resolve.comp runs one thread per covered pixel instead of one per pixel (lavapipe
// executes both sides of every branch, so a background pixel of a full-screen pass costs as much
// as a shaded one; docs/rendering.md). After the header: pixel coordinates x | y << 16 [W * H]
// (1920x1080: 8.3 MB). The resolve's VkDispatchIndirectCommand is (kCoveredGroupsX, groups_y, 1)
// of 64 threads: groups_y = ceil(count / (64 * kCoveredGroupsX)), counted up by the compaction,
// so that 536 M listed pixels (a fully covered 16384 x 16384 image: 268 M, 2 GiB of visibility
// buffer on a GPU) stay below the 65535 workgroups per dimension that Vulkan guarantees (16 per
// row, before: 67 M pixels, enough for lavapipe's 128 MiB buffers only).
MDS_CONST(uint, kCoveredGroupsX, 128u);  // workgroups per row of the resolve dispatch (8192 threads)
MDS_STRUCT(CoveredPixelsHeader) {
  uint dispatch_x;  // kCoveredGroupsX (written by the host each frame)
  uint dispatch_y;  // ceil(count / (64 * kCoveredGroupsX)) (atomicMax)
  uint dispatch_z;  // 1
  uint count;       // covered pixels listed (atomic counter)
};

#ifdef __cplusplus
static_assert(sizeof(CoveredPixelsHeader) == 16);
static_assert(sizeof(GpuSprite) == 48);
static_assert(sizeof(SpriteDrawHeader) == 96);
static_assert(offsetof(SpriteDrawHeader, chunk_next) == 76);
static_assert(offsetof(GpuSprite, vis_id) == 40);
static_assert(offsetof(SpriteDrawHeader, raster_x) == 56);
static_assert(offsetof(SpriteDrawHeader, occluded) == 48);
static_assert(offsetof(SpriteDrawHeader, quad_vertex_count) == 16);
static_assert(offsetof(SpriteDrawHeader, dispatch_x) == 32);
static_assert(sizeof(FrameUniforms) == 368 + 16 * kColormapSamples);
static_assert(offsetof(FrameUniforms, colormap) == 368);
static_assert(offsetof(FrameUniforms, cell) == 288);
static_assert(offsetof(FrameUniforms, ao) == 272);
static_assert(offsetof(FrameUniforms, color_plane) == 256);
static_assert(offsetof(FrameUniforms, viewport) == 192);
static_assert(offsetof(FrameUniforms, counts) == 224);
static_assert(offsetof(FrameUniforms, occlusion) == 240);
static_assert(sizeof(GpuNode) == 144);
static_assert(offsetof(GpuNode, occupancy_fine) == 80);
static_assert(offsetof(GpuNode, occupancy_lo) == 64);
static_assert(offsetof(GpuNode, first_particle) == 12);
static_assert(offsetof(GpuNode, step) == 16);
static_assert(offsetof(GpuNode, max_radius) == 44);
static_assert(offsetof(GpuNode, first_meshlet) == 60);
static_assert(offsetof(GpuNode, flags) == 72);
static_assert(sizeof(GpuMeshlet) == 48);
static_assert(offsetof(GpuMeshlet, node) == 12);
static_assert(offsetof(GpuMeshlet, first_particle) == 28);
static_assert(offsetof(GpuMeshlet, particle_count) == 32);
static_assert(offsetof(GpuMeshlet, split) == 36);
static_assert(offsetof(GpuMeshlet, second_particle) == 40);
static_assert(sizeof(GpuType) == 32);
static_assert(sizeof(DrawListHeader) == 32);
static_assert(offsetof(DrawListHeader, dispatch_x) == 20);  // VkDispatchIndirectCommand: 4-byte aligned
}  // namespace mds::gpu
#undef MDS_STRUCT
#undef MDS_CONST
#endif

#endif  // MDS_GPU_TYPES_H
