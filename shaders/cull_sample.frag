#version 460
// Occlusion sampling pass, rasterized route, fragment: the sample of include/cull_sample.h at
// this (jittered) pixel sample, (view depth of the hit, alpha_s). The depth attachment keeps the
// nearest sample. (The compute route, cull_sample.comp, computes the same samples.)
// Built with MDS_CULL_SAMPLE_ATOMIC (cull_sample_atomic.frag, 64-bit atomics): the compute
// route's large sprites, written into its sample buffer by the same atomicMin as cull_sample.comp
// (the depth attachment then only prunes fragments behind other large sprites).
#extension GL_GOOGLE_include_directive : require
#ifdef MDS_CULL_SAMPLE_ATOMIC
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#endif
#include "bindings.h"
#include "culling_math.glsl"
#include "cull_shared.h"
#include "cull_sample.h"

layout(push_constant) uniform PushBlock { CullPush push; };  // jitter (NDC), see cull_sample.vert

layout(location = 0) flat in vec4 v_center_radius;
#ifdef MDS_CULL_SAMPLE_ATOMIC
layout(std430, set = 1, binding = kCullSampleBuffer) coherent buffer SampleBlock { uint64_t samples[]; };
#else
layout(location = 0) out vec2 o_sample;
#endif
layout(depth_greater) out float gl_FragDepth;

void main() {
  vec2 ndc = gl_FragCoord.xy * frame.viewport.zw * 2.0 - 1.0 - vec2(push.jitter_x, push.jitter_y);
  float depth;
  vec2 s;
  if (!mds_cull_sample(ndc, v_center_radius, depth, s)) discard;
  gl_FragDepth = depth;
#ifdef MDS_CULL_SAMPLE_ATOMIC
  if (!(depth < 1.0)) return;  // what the depth test against the cleared 1.0 drops
  uint pix = uint(gl_FragCoord.y) * uint(frame.viewport.x) + uint(gl_FragCoord.x);
  atomicMin(samples[pix], (uint64_t(floatBitsToUint(max(s.x, 0.0))) << 32) | uint64_t(floatBitsToUint(s.y)));
#else
  o_sample = s;
#endif
}
