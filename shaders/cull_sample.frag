#version 460
// Occlusion sampling pass, fragment: exact ray-sphere hit at this (jittered) pixel sample as in
// sphere.frag; writes (view depth of the hit, alpha_s) where alpha_s is the effective sub-pixel
// area of the particle (paper 000, Sect. 4.1 "Particle sizes": mds_effective_particle_area of
// the projected radius in pixels; perspective: r f / z_centre with f the focal length in pixels,
// orthographic: r / pixel size). The depth attachment keeps the nearest sample.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "culling_math.glsl"
#include "cull_shared.h"

layout(push_constant) uniform PushBlock { CullPush push; };  // jitter (NDC), see cull_sample.vert

layout(location = 0) flat in vec4 v_center_radius;
layout(location = 0) out vec2 o_sample;
layout(depth_greater) out float gl_FragDepth;

void main() {
  vec2 ndc = gl_FragCoord.xy * frame.viewport.zw * 2.0 - 1.0 - vec2(push.jitter_x, push.jitter_y);
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
  if (t < 0.0) discard;
  vec3 p = o + t * d;
  vec4 clip = frame.proj * vec4(p, 1.0);
  gl_FragDepth = clip.z / clip.w;
  bool ortho = (frame.counts.z & kFrameOrtho) != 0u;
  // proj[1][1] = -g (perspective, g = 1/tan(fov/2)) or -1/half height (ortho).
  float px_per_unit = 0.5 * frame.viewport.y * abs(frame.proj[1][1]);
  float r_px = ortho ? r * px_per_unit : r * px_per_unit / max(-c.z, 1e-30);
  o_sample = vec2(-p.z, mds_effective_particle_area(r_px));
}
