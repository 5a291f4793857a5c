#version 460
// Occlusion sampling pass, rasterized route, fragment: the sample of include/cull_sample.h at
// this (jittered) pixel sample, (view depth of the hit, alpha_s). The depth attachment keeps the
// nearest sample. (The compute route, cull_sample.comp, computes the same samples.)
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "culling_math.glsl"
#include "cull_shared.h"
#include "sphere_shading.h"
#include "cull_sample.h"

layout(push_constant) uniform PushBlock { CullPush push; };  // jitter (NDC), see cull_sample.vert

layout(location = 0) flat in vec4 v_center_radius;
layout(location = 1) flat in vec3 v_disk;
layout(location = 0) out vec2 o_sample;
layout(depth_greater) out float gl_FragDepth;

void main() {
  vec2 ndc = gl_FragCoord.xy * frame.viewport.zw * 2.0 - 1.0 - vec2(push.jitter_x, push.jitter_y);
  float depth;
  vec2 s;
  if (!mds_cull_sample(ndc, floor(gl_FragCoord.xy), v_center_radius, v_disk, depth, s)) discard;
  gl_FragDepth = depth;
  o_sample = s;
}
