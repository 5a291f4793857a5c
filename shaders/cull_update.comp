#version 460
// Double-buffered depth confidence update (paper 000, Sect. 4.3, Algorithm 1; with kCullExtendDepth
// the depth extension of confidence_buffer.h extend_accumulation) for the depth
// sample of one occlusion sampling pass: per pixel with a sample (d_s, alpha_s),
// mds_update_depth_and_confidence_fronts with the acceptance probability P(d_s) of Eq. 13-22
// (normal approximation of supplement A, or the 50:50 coin), u uniform in (0, 1] from a hash of
// the pixel, the sampling pass (push.pass) and the seed. Writes the cull buffer (d_cull, C_cull)
// into pyramid level 0.
// Cost per pixel: O(1). The histograms are stored cumulatively (cull_histogram.comp), so each of
// the three density queries D(d_min, x) for x = d, d_cull, d_s is two loads (cull_hist_front),
// and D(d_min, d_max) one; no per-pixel copy of the bins.
#extension GL_GOOGLE_include_directive : require
#include "cull_shared.h"
// The normal CDF table from a buffer, not culling_math.glsl's constant array (see there).
layout(std430, set = 1, binding = kCullNormalCdf) readonly buffer NormalCdfBlock { float normal_cdf[]; };
#define MDS_NORMAL_CDF_AT(i) normal_cdf[i]
#include "culling_math.glsl"
#include "cull_bindings.h"
#include "pixel_list.glsl"

// Specialization constant 1 (kSampledList, compute route only): one thread per pixel of the
// sampled-pixel list (cull_sample_compact.comp), dispatched indirectly as (kCoveredGroupsX, y, 1)
// workgroups of 64; else one thread per pixel of the image. Constants 2/3: the local size.
layout(constant_id = 1) const bool kSampledList = false;
layout(local_size_x_id = 2, local_size_y_id = 3) in;  // (64, 1) with the list, else (8, 8)
layout(set = 1, binding = kCullSampleImage, rg32f) uniform readonly image2D sample_image;
// The compute sampling route (cull_sample.comp) leaves its samples in a uint64 per pixel, read
// here as two words (no shaderInt64 needed): .x = alpha_s bits, .y = view depth bits (all ones,
// a NaN depth, where no sample landed). Specialization constant 0 selects it.
layout(constant_id = 0) const bool kSampleBuffer = false;
layout(std430, set = 1, binding = kCullSampleBuffer) readonly buffer SampleBlock { uvec2 sample_words[]; };

void main() {
  uvec2 p;
  uint W = cull_width(), H = cull_height();
  if (kSampledList) {
    uint i = mds_pixel_list_index();
    if (i >= sampled_head.count) return;
    p = mds_pixel_list_xy(sampled_pixels[i]);
  } else {
    p = gl_GlobalInvocationID.xy;
    if (p.x >= W || p.y >= H) return;
  }
  uint pix = p.y * W + p.x;
  vec2 s;
  if (kSampleBuffer) {
    uvec2 w = sample_words[pix];
    s = vec2(uintBitsToFloat(w.y), uintBitsToFloat(w.x));
  } else {
    s = imageLoad(sample_image, ivec2(p)).xy;
  }
  if (!(s.x < float(MDS_CULL_DEPTH_EMPTY))) return;  // no sample: state and level 0 unchanged
  vec4 acc = pixel_state[2u * pix], cb = pixel_state[2u * pix + 1u];
  int bins = int(cull.grid_dims.w);
  uint hist = (p.y / cull.pyramid.y) * cull.pyramid.z + p.x / cull.pyramid.y;  // the pixel's histogram block
  vec2 range = hist_range[hist];
  if (!(range.y > range.x)) bins = 0;
  uint base = hist * cull.grid_dims.w;
  float total = bins > 0 ? hist_counts[base + uint(bins - 1)] : 0.0;
  float F_d = cull_hist_front(base, bins, range.x, range.y, acc.x);
  float F_dcull = cull_hist_front(base, bins, range.x, range.y, cb.x);
  float F_ds = cull_hist_front(base, bins, range.x, range.y, s.x);
  float u = cull_uniform01(pix, push.pass, cull.counts.w);
  float d = acc.x, C = acc.y, k = acc.z, d_cull = cb.x, C_cull = cb.y, k_cull = cb.z;
  mds_update_depth_and_confidence_fronts(d, C, k, d_cull, C_cull, k_cull, F_d, F_dcull, F_ds, total,
                                         s.x, s.y, u, int(cull.params.x), int(cull.params.y),
                                         (cull.params.w & kCullExtendDepth) != 0u);
  pixel_state[2u * pix] = vec4(d, C, k, 0.0);
  pixel_state[2u * pix + 1u] = vec4(d_cull, C_cull, k_cull, 0.0);
  pyramid[pix] = vec2(d_cull, C_cull);
}
