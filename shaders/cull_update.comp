#version 460
// Double-buffered depth confidence update (paper 000, Sect. 4.3, Algorithm 1) for the depth
// sample of this iteration's occlusion sampling pass: per pixel with a sample (d_s, alpha_s),
// mds_update_depth_and_confidence with the acceptance probability P(d_s) of Eq. 13-22 (normal
// approximation of supplement A, or the 50:50 coin), u uniform in (0, 1] from a hash of the
// pixel, the iteration and the seed. Writes the cull buffer (d_cull, C_cull) into pyramid level 0.
#extension GL_GOOGLE_include_directive : require
#include "culling_math.glsl"
#include "cull_bindings.h"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 1, binding = kCullSampleImage, rg32f) uniform readonly image2D sample_image;

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;
  uint W = cull_width(), H = cull_height();
  if (p.x >= W || p.y >= H) return;
  uint pix = p.y * W + p.x;
  vec4 acc = pixel_state[2u * pix], cb = pixel_state[2u * pix + 1u];
  vec2 s = imageLoad(sample_image, ivec2(p)).xy;
  if (s.x < float(MDS_CULL_DEPTH_EMPTY)) {
    int bins = int(cull.grid_dims.w);
    vec2 range = hist_range[pix];
    float counts[MDS_CULL_HISTOGRAM_BINS];
    for (int b = 0; b < MDS_CULL_HISTOGRAM_BINS; ++b)
      counts[b] = b < bins ? hist_counts[pix * uint(bins) + uint(b)] : 0.0;
    if (!(range.y > range.x)) bins = 0;
    float u = cull_uniform01(pix, cull.counts.z, cull.counts.w);
    float d = acc.x, C = acc.y, k = acc.z, d_cull = cb.x, C_cull = cb.y, k_cull = cb.z;
    mds_update_depth_and_confidence(d, C, k, d_cull, C_cull, k_cull, counts, bins, range.x, range.y,
                                    s.x, s.y, u, int(cull.params.x), int(cull.params.y));
    acc = vec4(d, C, k, 0.0);
    cb = vec4(d_cull, C_cull, k_cull, 0.0);
    pixel_state[2u * pix] = acc;
    pixel_state[2u * pix + 1u] = cb;
  }
  pyramid[pix] = cb.xy;
}
