#version 460
// Compute rasterization of the small sprites (visibility route): one thread per sprite that the
// pre-pass (sphere_prepass.comp) listed as at most kSmallPx pixels wide and high, each writing
// its pixels into the visibility buffer (sprite_raster.h: exact ray test, 64-bit atomicMin of
// depth and the sprite's vis_id). Dispatched indirectly (SpriteDrawHeader.raster_*). A separate pass
// rather than inside the pre-pass, whose threads each walk a whole meshlet: there the SIMD lanes
// (8 meshlets side by side on lavapipe) wait for the slowest lane, so sprites that are hidden
// (off screen, or by the particle occlusion test) saved nothing; listed here, the lanes hold
// neighbouring sprites of similar size and hidden ones cost nothing.
#extension GL_GOOGLE_include_directive : require
#define MDS_VISIBILITY
#include "bindings.h"
#include "sphere_shading.h"
#include "sprite_raster.h"

layout(local_size_x = 64) in;

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= sprite_draw.small_count) return;
  uint id = quad_ids[mds_small_sprite_slot(i)];
  GpuSprite s = sprites[id];
  raster_small_sprite(s, s.vis_id);
}
