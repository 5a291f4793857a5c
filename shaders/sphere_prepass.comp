#version 460
// Sprite pre-pass: for every particle of the meshlets in the current chunk of the draw list
// (sprite_args.comp; gpu_types.h SpriteDrawHeader, "Chunks"), computes once what the vertex stage
// needs (compute runs on all of lavapipe's threads; its vertex stage mostly on one): the glyph of
// include/sprite_make.h (conservative screen rectangle, depth, view-space sphere, and the
// particle's frame-wide id in the visibility buffer).
// One thread per chunk entry: one atomicAdd reserves the meshlet's run of sprites.
// After convergence each sprite first takes the particle occlusion test (particle_occlusion.h):
// a particle of a potentially visible meshlet that is class O on its own is hidden, and counted.
// kSmallPx > 0 (visibility route): sprites whose rectangle is at most kSmallPx pixels wide and
// high are listed (one atomicAdd per meshlet) for the compute rasterization (sprite_raster.comp)
// instead of the rasterizer: lavapipe sets up primitives on one thread at ~1 us each, which
// dominates small glyphs.
// kPoints: of the others, sprites whose rectangle centre lies on screen and whose square fits
// the point size are drawn as points (one vertex each); the rest are appended to the quad list.
#extension GL_GOOGLE_include_directive : require
#define MDS_SPRITES_WRITABLE
#define MDS_COLOR_KEY  // sprite_make.h: colour keys carry the property (kBindProperty)
#include "bindings.h"
#include "sphere_shading.h"
#include "sprite_make.h"
#include "culling_math.glsl"
#include "particle_occlusion.h"
#include "dispatch_rows.h"

layout(local_size_x = 64) in;
layout(constant_id = 0) const bool kPoints = false;
layout(constant_id = 1) const float kMaxPointSize = 1.0;
layout(constant_id = 2) const float kSmallPx = 0.0;
// The particle occlusion test is compiled in only where it can run (after convergence): lavapipe
// executes a branch's code even when the branch is not taken, and the test cost the pre-pass
// ~10-15 ms per 1920x1080 frame while switched off by the uniform (docs/rendering.md).
layout(constant_id = 3) const bool kParticleOcclusion = false;
// Visibility ids (GpuSprite.vis_id): the sprite's record index where the frame draws its list in
// one chunk (the resolve reads the record), the particle's frame-wide id where it draws in
// several (the records are reused; the resolve rebuilds the sphere). gpu_types.h GpuSprite.
layout(constant_id = 4) const bool kChunkedIds = false;

void main() {
  uint t = mds_flat_id();
  if (t >= sprite_draw.chunk_count) return;
  uint e = sprite_draw.chunk_first + t;
  GpuMeshlet m = meshlets[draw_ids[e]];
  GpuNode node = nodes[m.node];
  uint count = m.particle_count;
  uint base = kPoints ? atomicAdd(sprite_draw.point_vertex_count, count)
                      : atomicAdd(sprite_draw.quad_vertex_count, 6u * count) / 6u;
  if (base + count > sprite_draw.capacity) return;  // a list with repeated meshlets (never expected)
  uint occluded = 0u, small = 0u, offscreen = 0u;
  for (uint local = 0u; local < count; ++local) {
    GpuSprite s = mds_make_sprite(m, node, local, e);
    if (!kChunkedIds) s.vis_id = base + local;
    if ((s.flags & kSpriteHidden) != 0u) ++offscreen;
    if (kParticleOcclusion && (s.flags & kSpriteHidden) == 0u && mds_particle_occluded(s)) {
      s.flags |= kSpriteHidden;
      ++occluded;
    }
    if ((s.flags & kSpriteHidden) == 0u) {
      vec2 ndc_lo = s.rect.xy, ndc_hi = s.rect.zw;
      vec2 side_px = (ndc_hi - ndc_lo) * 0.5 * frame.viewport.xy;
      if (kSmallPx > 0.0 && max(side_px.x, side_px.y) <= kSmallPx) {
        s.flags |= kSpriteSmall;
        ++small;
      } else if (kPoints) {
        vec2 mid = 0.5 * (ndc_lo + ndc_hi);
        bool on_screen = all(lessThan(abs(mid), vec2(1.0)));
        if (!on_screen || max(side_px.x, side_px.y) + 1.0 > kMaxPointSize) {
          s.flags |= kSpriteQuad;
          uint qi = atomicAdd(sprite_draw.quad_vertex_count, 6u) / 6u;
          quad_ids[qi] = base + local;
        }
      }
    }
    sprites[base + local] = s;
  }
  atomicAdd(sprite_draw.listed, count);
  if (occluded > 0u) atomicAdd(sprite_draw.occluded, occluded);
  if (offscreen > 0u) atomicAdd(sprite_draw.offscreen, offscreen);
  if (small > 0u) {
    // One run of the small list for this meshlet, and the rasterization's workgroups: one per 64
    // entries, counted by the run that reaches each multiple of 64.
    atomicAdd(sprite_draw.small_total, small);
    uint first = atomicAdd(sprite_draw.small_count, small);
    uint groups = (first + small + 63u) / 64u - (first + 63u) / 64u;
    if (groups > 0u) atomicAdd(sprite_draw.raster_x, groups);
    for (uint local = 0u; local < count; ++local)
      if ((sprites[base + local].flags & kSpriteSmall) != 0u) quad_ids[mds_small_sprite_slot(first++)] = base + local;
  }
}
