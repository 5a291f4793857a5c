#version 460
// Progressive super-sampling: adds this pass's colour (rgb, a = coverage) to the float
// accumulation image; the final image is accum / spp. Timing frames (kFrameTimingOnly) add it
// with weight 0: the same work, the image unchanged.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = kBindColorImage, rgba32f) uniform readonly image2D color_image;
layout(set = 0, binding = kBindAccumImage, rgba32f) uniform image2D accum_image;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= int(frame.viewport.x) || p.y >= int(frame.viewport.y)) return;
  float weight = (frame.counts.z & kFrameTimingOnly) != 0u ? 0.0 : 1.0;
  imageStore(accum_image, p, imageLoad(accum_image, p) + weight * imageLoad(color_image, p));
}
