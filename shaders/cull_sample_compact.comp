#version 460
// Compute sampling route, before the update (Algorithm 1): lists the pixels that received a
// sample in this pass (the sample buffer's depth word is a depth below MDS_CULL_DEPTH_EMPTY, the
// test cull_update.comp applies) as x | y << 16 and sizes the update's indirect dispatch, so that
// the update runs one thread per sampled pixel. On lavapipe a branch does not skip work (both
// sides run for every SIMD lane, docs/rendering.md), so the full-screen update paid the density
// queries and the acceptance probability for every pixel without a sample; this pass reads
// 4 bytes per pixel instead. One atomic per subgroup (pixel_list.glsl).
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "cull_shared.h"
#include "culling_math.glsl"
#include "cull_bindings.h"
#include "pixel_list.glsl"

layout(std430, set = 1, binding = kCullSampleBuffer) readonly buffer SampleWords { uint sample_words[]; };

layout(local_size_x = 16, local_size_y = 16) in;

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;
  uint W = cull_width(), H = cull_height();
  bool sampled = false;
  if (p.x < W && p.y < H) sampled = uintBitsToFloat(sample_words[2u * (p.y * W + p.x) + 1u]) < float(MDS_CULL_DEPTH_EMPTY);
  MDS_PIXEL_LIST_APPEND(sampled_head, sampled_pixels, sampled, p)
}
