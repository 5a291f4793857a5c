#version 460
// Draw list -> sprite commands: resets the two sprite draw commands (the pre-pass counts into
// them) and sizes the pre-pass dispatch to the list length (one thread per listed meshlet).
#extension GL_GOOGLE_include_directive : require
#define MDS_SPRITES_WRITABLE
#include "bindings.h"

layout(local_size_x = 1) in;

void main() {
  uint n = draw_header.instance_count;
  sprite_draw.point_vertex_count = 0u;
  sprite_draw.point_instance_count = 1u;
  sprite_draw.point_first_vertex = 0u;
  sprite_draw.point_first_instance = 0u;
  sprite_draw.quad_vertex_count = 0u;
  sprite_draw.quad_instance_count = 1u;
  sprite_draw.quad_first_vertex = 0u;
  sprite_draw.quad_first_instance = 0u;
  sprite_draw.occluded = 0u;
  sprite_draw.offscreen = 0u;
  sprite_draw.small_count = 0u;
  sprite_draw.raster_x = 0u;
  sprite_draw.raster_y = 1u;
  sprite_draw.raster_z = 1u;
  sprite_draw.dispatch_x = (n + 63u) / 64u;
  sprite_draw.dispatch_y = 1u;
  sprite_draw.dispatch_z = 1u;
}
