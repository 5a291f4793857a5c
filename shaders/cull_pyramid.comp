#version 460
// Depth confidence pyramid (paper 000, Sect. 4.6, Eq. 23): level push.mode (>= 1) from level
// push.mode - 1: depth = max, confidence = mean over the 2x2 block (partial blocks at odd
// borders: over the 1 or 2 pixels that exist), mds_pyramid_depth / mds_pyramid_confidence.
#extension GL_GOOGLE_include_directive : require
#include "culling_math.glsl"
#include "cull_bindings.h"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  uint l = push.mode;
  uvec2 fs = cull_level_size(l - 1u), cs = cull_level_size(l);
  uvec2 p = gl_GlobalInvocationID.xy;
  if (p.x >= cs.x || p.y >= cs.y) return;
  uint fo = cull_level_offset(l - 1u), co = cull_level_offset(l);
  uint x0 = 2u * p.x, y0 = 2u * p.y;
  bool right = x0 + 1u < fs.x, below = y0 + 1u < fs.y;
  uint x1 = right ? x0 + 1u : x0, y1 = below ? y0 + 1u : y0;
  vec2 a = pyramid[fo + y0 * fs.x + x0], b = pyramid[fo + y0 * fs.x + x1];
  vec2 c = pyramid[fo + y1 * fs.x + x0], d = pyramid[fo + y1 * fs.x + x1];
  pyramid[co + p.y * cs.x + p.x] = vec2(mds_pyramid_depth(a.x, b.x, c.x, d.x, right, below),
                                        mds_pyramid_confidence(a.y, b.y, c.y, d.y, right, below));
}
