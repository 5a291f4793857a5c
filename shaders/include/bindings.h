// GLSL-only: the renderer's descriptor set (set 0), as laid out in gpu_types.h (kBind*).
// A shader that writes the draw list defines MDS_DRAW_LIST_WRITABLE before including this.
// (bindings are declared only; a shader that uses none of a binding does not reference it)
#ifndef MDS_BINDINGS_H
#define MDS_BINDINGS_H
#ifndef __cplusplus

#include "gpu_types.h"

#ifdef MDS_DRAW_LIST_WRITABLE
#define MDS_DRAW_LIST_ACCESS
#else
#define MDS_DRAW_LIST_ACCESS readonly
#endif

layout(std140, set = 0, binding = kBindFrame) uniform FrameBlock { FrameUniforms frame; };
layout(std430, set = 0, binding = kBindNodes) readonly buffer NodeBlock { GpuNode nodes[]; };
layout(std430, set = 0, binding = kBindMeshlets) readonly buffer MeshletBlock { GpuMeshlet meshlets[]; };
// Particle i: x = p.x & 0xffff, y = p.x >> 16, z = p.y & 0xffff, type = (p.y >> 16) & 0xff.
layout(std430, set = 0, binding = kBindParticles) readonly buffer ParticleBlock { uvec2 particles[]; };
layout(std430, set = 0, binding = kBindTypes) readonly buffer TypeBlock { GpuType types[]; };
layout(std430, set = 0, binding = kBindDrawList) MDS_DRAW_LIST_ACCESS buffer DrawListBlock {
  DrawListHeader draw_header;
  uint draw_ids[];
};
// Per-particle radius_q, two uint16 per uint (only with kFramePerParticleRadius).
layout(std430, set = 0, binding = kBindRadii) readonly buffer RadiusBlock { uint radii_q[]; };
// Per-particle property_q, two uint16 per uint (only with kFrameColorProperty).
layout(std430, set = 0, binding = kBindProperty) readonly buffer PropertyBlock { uint property_q[]; };
// Per-particle RGBA8 colours, R in bits 0..7 (only with kFrameColorParticle).
layout(std430, set = 0, binding = kBindColor) readonly buffer ColorBlock { uint particle_rgba[]; };
// Buffer index of a meshlet's local particle l (GpuMeshlet: at most two runs, see gpu_types.h).
uint mds_meshlet_particle(GpuMeshlet m, uint l) {
  return l < m.split ? m.first_particle + l : m.second_particle + (l - m.split);
}

// Sprite records and their draw commands; the pre-pass defines MDS_SPRITES_WRITABLE.
#ifdef MDS_SPRITES_WRITABLE
#define MDS_SPRITES_ACCESS
#else
#define MDS_SPRITES_ACCESS readonly
#endif
layout(std430, set = 0, binding = kBindSprites) MDS_SPRITES_ACCESS buffer SpriteBlock { GpuSprite sprites[]; };
layout(std430, set = 0, binding = kBindSpriteDraw) MDS_SPRITES_ACCESS buffer SpriteDrawBlock {
  SpriteDrawHeader sprite_draw;
  uint quad_ids[];  // [0, capacity): sprites drawn as quads; [capacity, 2 capacity): small sprites
};
uint mds_small_sprite_slot(uint i) { return sprite_draw.capacity + i; }  // quad_ids index of small sprite i
// Compute rasterization of small sprites (sprite_raster.h): per pixel one uint64, the nearest
// depth's float bits << 32 | that sprite's index, by 64-bit atomicMin; all ones = empty. Only the
// shaders that define MDS_VISIBILITY before including this file see it (they need shaderInt64).
// The culling loop's confidence pyramid (cull_bindings.h kCullPyramid: level 0 = per pixel (d_cull,
// C_cull), then max depth / mean confidence levels), read by the particle occlusion test of the
// sprite pre-pass after convergence (particle_occlusion.h). Without culling the test is off
// (frame.occlusion.z = 0, nothing is read) and the node buffer fills the binding.
layout(std430, set = 0, binding = kBindOcclusionPyramid) readonly buffer OcclusionPyramidBlock { vec2 occ_pyramid[]; };
#ifdef MDS_VISIBILITY
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
layout(std430, set = 0, binding = kBindVisibility) coherent buffer VisibilityBlock { uint64_t visibility[]; };
#endif
// The covered pixels of the visibility buffer (gpu_types.h CoveredPixelsHeader), written by
// visibility_compact.comp, read by visibility_resolve.comp.
layout(std430, set = 0, binding = kBindCoveredPixels) buffer CoveredPixelsBlock {
  CoveredPixelsHeader covered_head;
  uint covered_pixels[];
};

#endif
#endif  // MDS_BINDINGS_H
