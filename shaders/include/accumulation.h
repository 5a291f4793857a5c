// GLSL-only: the progressive super-sampling accumulation (rgb sum, a = coverage sum; the final
// image is accum / spp), shared by visibility_resolve.comp and accumulate.comp. Where
// 16 B/pixel fits maxStorageBufferRange (1920x1080: 33 MB; 3840x2160: 133 MB <= 128 MiB on
// lavapipe) it is a vec4 storage buffer, else an rgba32f storage image; specialization constant 0
// (kAccumBuffer) chooses, and the renderer binds a 1x1 image or a 16-byte buffer to the unused
// binding. Why a buffer: on lavapipe the image load + store of every pixel cost about 20 ms of a
// 1920x1080 resolve that took 70 (docs/rendering.md, "What the resolve costs").
#ifndef MDS_ACCUMULATION_H
#define MDS_ACCUMULATION_H

#include "bindings.h"

layout(constant_id = 0) const bool kAccumBuffer = true;
layout(set = 0, binding = kBindAccumImage, rgba32f) uniform image2D accum_image;
layout(std430, set = 0, binding = kBindAccumBuffer) buffer AccumBlock { vec4 accum[]; };

// Adds c to pixel p (inside the viewport).
void accumulate_pixel(ivec2 p, vec4 c) {
  if (kAccumBuffer) {
    uint i = uint(p.y) * uint(frame.viewport.x) + uint(p.x);
    accum[i] += c;
  } else {
    imageStore(accum_image, p, imageLoad(accum_image, p) + c);
  }
}

#endif  // MDS_ACCUMULATION_H
