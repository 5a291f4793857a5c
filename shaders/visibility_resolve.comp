#version 460
// Visibility route, last pass of a sampling frame: per covered pixel the nearest sphere of the
// visibility buffer (sprite_raster.h; written by the compute rasterization of small sprites and
// by the rasterized ones) is shaded once -- the same ray and shading as sphere.frag
// (sphere_shading.h) -- and added to the accumulation (accumulation.h). The buffer holds the
// winner's vis_id: its sprite record's index where the frame draws its list in one chunk, else
// (specialization constant 4, kChunkedIds: the records are reused chunk by chunk) the particle's
// frame-wide id, from which its sphere is rebuilt (sprite_make.h mds_vis_id_sphere: the
// pre-pass's bits; on lavapipe the chain of loads costs a 1080p full-screen resolve ~25 ms more
// than one record, so one chunk keeps the record). Background pixels add
// nothing: the accumulation holds the covered samples only (rgb sum, a = their count) and the
// host composes the background over it (Renderer::Impl::read_average). Timing frames
// (kFrameTimingOnly) add with weight 0: the same work, the image unchanged.
// Specialization constant 1 (kCoveredList): one thread per pixel of the covered-pixel list
// (visibility_compact.comp; dispatch (kCoveredGroupsX, y, 1) of 64 threads) -- or, where the
// device lacks subgroup ballots in compute, one thread per pixel of the viewport (16x16 tiles).
#extension GL_GOOGLE_include_directive : require
#define MDS_VISIBILITY
#define MDS_COLOR_KEY  // sprite_make.h: colour keys carry the property (kBindProperty)
#include "bindings.h"
#include "particle_color.h"
#include "sphere_shading.h"
#include "sprite_make.h"
#include "accumulation.h"
#include "pixel_list.glsl"

layout(constant_id = 1) const bool kCoveredList = true;
layout(constant_id = 4) const bool kChunkedIds = false;
layout(local_size_x_id = 2, local_size_y_id = 3) in;  // (64, 1) with the list, else (16, 16)

void main() {
  ivec2 p;
  if (kCoveredList) {
    uint i = mds_pixel_list_index();
    if (i >= covered_head.count) return;
    p = ivec2(mds_pixel_list_xy(covered_pixels[i]));
  } else {
    p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(frame.viewport.x) || p.y >= int(frame.viewport.y)) return;
  }
  uint id = uint(visibility[uint(p.y) * uint(frame.viewport.x) + uint(p.x)] & 0xffffffffu);
  if (id == kVisEmpty) return;  // background: nothing to add
  uint type;
  vec4 center_radius;
  if (kChunkedIds) {
    center_radius = mds_vis_id_sphere(id, type);
  } else {
    GpuSprite s = sprites[id];
    center_radius = s.center_radius;
    type = s.flags;  // colour key: type and property (sprite_make.h)
  }
  vec3 hit, n, d;
  float depth;
  if (!ray_sphere(vec2(p) + 0.5, center_radius, hit, n, d, depth)) return;
  float weight = (frame.counts.z & kFrameTimingOnly) != 0u ? 0.0 : 1.0;
  accumulate_pixel(p, weight * shade_sphere(n, d, mds_particle_color(type, center_radius.xyz)));
}
