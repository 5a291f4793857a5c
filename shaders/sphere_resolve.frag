#version 460
// Resolve of the compute-rasterized small sprites (sprite_raster.h): per pixel, the nearest
// sprite's hit, shaded and with its depth exactly as sphere.frag would (sphere_shading.h).
// Drawn first, as a full-screen triangle; the rasterized sprites then depth-test against it.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "sphere_shading.h"

layout(location = 0) out vec4 o_color;
layout(depth_greater) out float gl_FragDepth;

void main() {
  uvec2 px = uvec2(gl_FragCoord.xy);
  uint w = uint(frame.viewport.x);
  uint wh = w * uint(frame.viewport.y);
  uint id = visibility[wh + px.y * w + px.x];
  if (id == 0xffffffffu) discard;
  GpuSprite s = sprites[id];
  vec3 p, n, d;
  float depth;
  if (!ray_sphere(gl_FragCoord.xy, s.center_radius, p, n, d, depth)) discard;
  gl_FragDepth = depth;
  o_color = shade_sphere(n, d, types[s.flags & 0xffu].color.rgb);
}
