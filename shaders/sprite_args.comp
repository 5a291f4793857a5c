#version 460
// Draw list -> sprite commands of the next chunk (gpu_types.h SpriteDrawHeader, "Chunks"): the
// chunk is the chunk_meshlets list entries from chunk_next on (the host zeroes chunk_next before
// a frame's first chunk); resets the two sprite draw commands and the small-sprite list (the
// pre-pass counts into them) and sizes the pre-pass dispatch to the chunk (one thread per listed
// meshlet; the task/mesh path takes it as its launch size). The frame's totals (occluded,
// offscreen, listed, small_total) are reset by the first chunk only.
#extension GL_GOOGLE_include_directive : require
#define MDS_SPRITES_WRITABLE
#include "bindings.h"
#include "dispatch_rows.h"

layout(local_size_x = 1) in;

void main() {
  uint n = draw_header.instance_count;
  uint first = sprite_draw.chunk_next;
  uint count = first < n ? min(n - first, sprite_draw.chunk_meshlets) : 0u;
  sprite_draw.chunk_first = first;
  sprite_draw.chunk_count = count;
  sprite_draw.chunk_next = first + count;
  if (first == 0u) {
    sprite_draw.occluded = 0u;
    sprite_draw.offscreen = 0u;
    sprite_draw.listed = 0u;
    sprite_draw.small_total = 0u;
  }
  sprite_draw.point_vertex_count = 0u;
  sprite_draw.point_instance_count = 1u;
  sprite_draw.point_first_vertex = 0u;
  sprite_draw.point_first_instance = 0u;
  sprite_draw.quad_vertex_count = 0u;
  sprite_draw.quad_instance_count = 1u;
  sprite_draw.quad_first_vertex = 0u;
  sprite_draw.quad_first_instance = 0u;
  sprite_draw.small_count = 0u;
  sprite_draw.raster_x = 0u;
  sprite_draw.raster_y = 1u;
  sprite_draw.raster_z = 1u;
  uvec3 rows = mds_dispatch_rows((count + 63u) / 64u, kDispatchRow);  // the pre-pass's 64 / the task stage's kMeshTaskMeshlets
  sprite_draw.dispatch_x = rows.x;
  sprite_draw.dispatch_y = rows.y;
  sprite_draw.dispatch_z = rows.z;
}
