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
#include "ambient_occlusion.glsl"

layout(constant_id = 1) const bool kCoveredList = true;
layout(constant_id = 4) const bool kChunkedIds = false;
layout(local_size_x_id = 2, local_size_y_id = 3) in;  // (64, 1) with the list, else (16, 16)

// The view-space point that pixel q shows (its centre's ray on its nearest sphere, from the depth
// in the visibility word's high bits); false for a background pixel.
bool visible_point(ivec2 q, out vec3 pos) {
  uint64_t v = visibility[uint(q.y) * uint(frame.viewport.x) + uint(q.x)];
  pos = vec3(0.0);
  uint id = uint(v & 0xffffffffu);
  if (id == kVisEmpty || id == kVisCell) return false;  // the cell's lines occlude nothing
  vec2 ndc = (vec2(q) + 0.5) * frame.viewport.zw * 2.0 - 1.0;
  vec4 h = frame.inv_proj * vec4(ndc, uintBitsToFloat(uint(v >> 32)), 1.0);
  pos = h.xyz / h.w;
  return true;
}

// Ambient obscurance A of the point C with normal n (view space) shown by pixel p: the SAO taps
// (ambient_occlusion.glsl) on the other pixels' visible points within frame.ao.x of C. A radius
// below a pixel resolves nothing: 1.
float ambient_obscurance(ivec2 p, vec3 C, vec3 n) {
  float r = frame.ao.x;
  bool ortho = (frame.counts.z & kFrameOrtho) != 0u;
  float rpx = mds_ao_screen_radius(r, abs(frame.proj[1][1]), frame.viewport.y, -C.z, ortho);
  if (!(rpx >= 1.0)) return 1.0;
  float spin = mds_ao_spin(uint(p.x), uint(p.y), frame.counts.w);
  ivec2 size = ivec2(frame.viewport.xy);
  float sum = 0.0;
  for (int i = 0; i < MDS_AO_TAPS; ++i) {
    float dx, dy;
    mds_ao_tap_offset(i, MDS_AO_TAPS, spin, rpx, dx, dy);
    ivec2 q = p + ivec2(round(vec2(dx, dy)));
    if (q == p || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
    vec3 Q;
    if (!visible_point(q, Q)) continue;
    vec3 u = (Q - C) / r;
    sum += mds_ao_tap(u.x, u.y, u.z, n.x, n.y, n.z);
  }
  return mds_ao_obscurance(sum, MDS_AO_TAPS, frame.ao.y);
}

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
  float weight = (frame.counts.z & kFrameTimingOnly) != 0u ? 0.0 : 1.0;
  if (id == kVisCell) {  // the simulation cell's edges (cell_lines.frag): flat colour
    accumulate_pixel(p, weight * vec4(frame.cell[4].rgb, 1.0));
    return;
  }
  uint type, rgba;
  vec4 center_radius;
  if (kChunkedIds) {
    center_radius = mds_vis_id_sphere(id, type, rgba);
  } else {
    GpuSprite s = sprites[id];
    center_radius = s.center_radius;
    type = s.flags;  // colour key: type and property (sprite_make.h)
    rgba = s.color;
  }
  vec3 hit, n, d;
  float depth;
  if (!ray_sphere(vec2(p) + 0.5, center_radius, hit, n, d, depth)) return;
  vec4 c = shade_sphere(n, d, mds_particle_color(type, rgba, center_radius.xyz));
  if (frame.ao.y > 0.0) c.rgb *= ambient_obscurance(p, hit, n);
  accumulate_pixel(p, weight * c);
}
