#version 460
// Start of a view (paper 000, Sect. 5.1: "every time the view has changed, all meshlets are put
// into class P"): per pixel, the accumulation and cull buffers of Algorithm 1 start empty
// (d = d_cull = MDS_CULL_DEPTH_EMPTY, C = k = 0) and pyramid level 0 with them.
#extension GL_GOOGLE_include_directive : require
#include "culling_math.glsl"
#include "cull_bindings.h"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;
  uint W = cull_width(), H = cull_height();
  if (p.x >= W || p.y >= H) return;
  uint pix = p.y * W + p.x;
  vec4 empty = vec4(float(MDS_CULL_DEPTH_EMPTY), 0.0, 0.0, 0.0);
  pixel_state[2u * pix] = empty;
  pixel_state[2u * pix + 1u] = empty;
  pyramid[pix] = empty.xy;
}
