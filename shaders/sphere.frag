#version 460
// Exact sphere ray casting inside the billboard (include/sphere_shading.h): discard on a
// miss, else the hit's depth and shading.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "sphere_shading.h"

layout(location = 0) flat in vec4 v_center_radius;
layout(location = 1) flat in vec3 v_color;
layout(location = 0) out vec4 o_color;
layout(depth_greater) out float gl_FragDepth;

void main() {
  vec3 p, n, d;
  float depth;
  if (!ray_sphere(gl_FragCoord.xy, v_center_radius, p, n, d, depth)) discard;
  gl_FragDepth = depth;
  o_color = shade_sphere(n, d, v_color);
}
