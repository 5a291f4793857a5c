#version 460
// Visibility route, before the resolve: lists the covered pixels of the visibility buffer
// (gpu_types.h CoveredPixelsHeader) and sizes the resolve's indirect dispatch, so that the
// resolve runs one thread per covered pixel. On lavapipe a branch does not skip work (both sides
// run for every SIMD lane), so the full-screen resolve paid the ray test and shading for every
// background pixel; this pass reads 8 bytes per pixel instead (docs/rendering.md).
// One atomic per subgroup (pixel_list.glsl).
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "bindings.h"
#include "pixel_list.glsl"

// The visibility buffer as 32-bit words: the low word of pixel i (little-endian) is word 2 i,
// the sprite index; all ones = empty. Reading one word instead of the uint64 halves the loads
// and needs no shaderInt64.
layout(std430, set = 0, binding = kBindVisibility) readonly buffer VisibilityWords { uint visibility_words[]; };

layout(local_size_x = 16, local_size_y = 16) in;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  const uint w = uint(frame.viewport.x);
  const uint pix = uint(p.y) * w + uint(p.x);
  bool covered = p.x < int(frame.viewport.x) && p.y < int(frame.viewport.y) &&
                 visibility_words[2u * pix] != kVisEmpty;
  // Stored as x | y << 16 (viewport <= 16384): the resolve needs no integer division (lavapipe
  // has no SIMD division; a per-lane pix % w, pix / w cost ~10 ms per 1920x1080 frame).
  MDS_PIXEL_LIST_APPEND(covered_head, covered_pixels, covered, p)
}
