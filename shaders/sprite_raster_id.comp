#version 460
// Second pass of the compute rasterization of small sprites (sprite_raster.h): every small
// sprite of the draw list writes its index into the pixels where it is the nearest. One thread
// per list entry, over the run of sprites the pre-pass reserved for that meshlet.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "sphere_shading.h"
#include "sprite_raster.h"

layout(local_size_x = 64) in;

void main() {
  uint e = gl_GlobalInvocationID.x;
  if (e >= draw_header.instance_count) return;
  uint count = meshlets[draw_ids[e]].particle_count;
  uint base = quad_ids[sprite_draw.capacity + e];
  if (base + count > sprite_draw.capacity) return;
  for (uint i = 0u; i < count; ++i) {
    GpuSprite s = sprites[base + i];
    if ((s.flags & kSpriteSmall) != 0u) raster_small_sprite(s, base + i, true);
  }
}
