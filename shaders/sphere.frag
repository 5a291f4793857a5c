#version 460
// Exact sphere ray casting inside the billboard (include/sphere_shading.h): discard on a miss.
// Attachment route: the hit's depth and shading into the depth and colour attachments.
// Visibility route (built as sphere_vis.frag with MDS_VISIBILITY_ROUTE): no attachments; the
// hit's depth and the sprite's vis_id go into the visibility buffer (sprite_raster.h), and
// visibility_resolve.comp shades each pixel once.
#extension GL_GOOGLE_include_directive : require
#ifdef MDS_VISIBILITY_ROUTE
#define MDS_VISIBILITY
#endif
#include "bindings.h"
#include "sphere_shading.h"
#ifdef MDS_VISIBILITY_ROUTE
#include "sprite_raster.h"
#endif

layout(location = 0) flat in vec4 v_center_radius;
layout(location = 1) flat in vec3 v_color;
layout(location = 2) flat in uint v_sprite;

#ifdef MDS_VISIBILITY_ROUTE
void main() {
  uint pix = uint(gl_FragCoord.y) * uint(frame.viewport.x) + uint(gl_FragCoord.x);
  // Early depth test (as raster_small_sprite's): the billboard lies at the sphere's nearest depth,
  // which bounds every hit's depth from below; a pixel already holding a nearer hit cannot take
  // this sphere, so the ray test is skipped (with a little slack for rounding).
  if (floatBitsToUint(gl_FragCoord.z * (1.0 - 1e-5)) > uint(visibility[pix] >> 32)) return;
  vec3 p, n, d;
  float depth;
  if (!ray_sphere(gl_FragCoord.xy, v_center_radius, p, n, d, depth)) return;
  visibility_write(pix, depth, v_sprite);
}
#else
layout(location = 0) out vec4 o_color;
layout(depth_greater) out float gl_FragDepth;

void main() {
  vec3 p, n, d;
  float depth;
  if (!ray_sphere(gl_FragCoord.xy, v_center_radius, p, n, d, depth)) discard;
  gl_FragDepth = depth;
  o_color = shade_sphere(n, d, v_color);
}
#endif
