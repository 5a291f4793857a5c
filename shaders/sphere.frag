#version 460
// Exact sphere ray casting inside the billboard. The ray of this fragment is the line through
// the unprojected near (z_ndc = 0) and far (z_ndc = 1) points of the pixel centre, which is
// right for perspective and orthographic projections alike (and includes the sub-pixel jitter,
// which lives in the projection matrix). Intersection uses the numerically stable form
// (Haines et al., Ray Tracing Gems ch. 7): disc = r^2 - |oc - (oc.d) d|^2.
// Depth: the hit point re-projected; shading: Lambert + Blinn-Phong with a headlight.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"

layout(location = 0) flat in vec4 v_center_radius;
layout(location = 1) flat in vec3 v_color;
layout(location = 0) out vec4 o_color;
layout(depth_greater) out float gl_FragDepth;

void main() {
  vec2 ndc = gl_FragCoord.xy * frame.viewport.zw * 2.0 - 1.0;
  vec4 pn = frame.inv_proj * vec4(ndc, 0.0, 1.0);
  vec4 pf = frame.inv_proj * vec4(ndc, 1.0, 1.0);
  vec3 o = pn.xyz / pn.w;
  vec3 d = normalize(pf.xyz / pf.w - o);
  vec3 c = v_center_radius.xyz;
  float r = v_center_radius.w;
  vec3 oc = o - c;
  float b = dot(oc, d);
  vec3 f = oc - b * d;
  float disc = r * r - dot(f, f);
  if (disc < 0.0) discard;
  float t = -b - sqrt(disc);
  if (t < 0.0) discard;  // front surface in front of the near plane
  vec3 p = o + t * d;
  vec3 n = (p - c) / r;
  vec4 clip = frame.proj * vec4(p, 1.0);
  gl_FragDepth = clip.z / clip.w;
  vec3 l = -d;  // headlight: light from the eye; the half vector equals l
  float ndl = max(dot(n, l), 0.0);
  float spec = pow(ndl, 48.0);
  o_color = vec4(v_color * (0.15 + 0.85 * ndl) + vec3(0.25 * spec), 1.0);
}
