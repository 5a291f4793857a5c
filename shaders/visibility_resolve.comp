#version 460
// Visibility route, last pass of a sampling frame: per pixel the nearest sprite of the
// visibility buffer (sprite_raster.h; written by the compute rasterization of small sprites and
// by the rasterized ones) is shaded once -- the same ray and shading as sphere.frag
// (sphere_shading.h) -- or the pixel takes the background (coverage 0), and the result is added
// to the accumulation (accumulation.h; the final image is accum / spp). Timing frames
// (kFrameTimingOnly) add it with weight 0: the same work, the image unchanged.
// Shading once per pixel replaces the colour attachment, the resolve draw and accumulate.comp.
#extension GL_GOOGLE_include_directive : require
#define MDS_VISIBILITY
#include "bindings.h"
#include "sphere_shading.h"
#include "accumulation.h"

layout(local_size_x = 16, local_size_y = 16) in;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= int(frame.viewport.x) || p.y >= int(frame.viewport.y)) return;
  uint id = uint(visibility[uint(p.y) * uint(frame.viewport.x) + uint(p.x)] & 0xffffffffu);
  vec4 c = vec4(frame.background.rgb, 0.0);
  if (id != 0xffffffffu) {
    GpuSprite s = sprites[id];
    vec3 hit, n, d;
    float depth;
    if (ray_sphere(vec2(p) + 0.5, s.center_radius, hit, n, d, depth))
      c = shade_sphere(n, d, types[s.flags & 0xffu].color.rgb);
  }
  float weight = (frame.counts.z & kFrameTimingOnly) != 0u ? 0.0 : 1.0;
  accumulate_pixel(p, weight * c);
}
