#version 460
// Progressive super-sampling (attachment route): adds this pass's colour (rgb, a = coverage) to
// the accumulation (accumulation.h); the final image is accum / spp. Timing frames
// (kFrameTimingOnly) add it with weight 0: the same work, the image unchanged.
#extension GL_GOOGLE_include_directive : require
#include "accumulation.h"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = kBindColorImage, rgba32f) uniform readonly image2D color_image;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= int(frame.viewport.x) || p.y >= int(frame.viewport.y)) return;
  float weight = (frame.counts.z & kFrameTimingOnly) != 0u ? 0.0 : 1.0;
  accumulate_pixel(p, weight * imageLoad(color_image, p));
}
