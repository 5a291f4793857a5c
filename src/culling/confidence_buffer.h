// CPU reference of the double-buffered depth confidence update (paper 000, Ibrahim et al. 2021,
// Sect. 4.3, Algorithm 1, with the acceptance probability of Sect. 4.5) and of the depth
// confidence pyramid (Sect. 4.6, Eq. 23). The GPU version mirrors update_depth_and_confidence
// (shaders/include/culling_math.glsl: mds_update_depth_and_confidence).
#pragma once

#include <vector>

#include "culling/culling_constants.h"
#include "culling/density_histogram.h"

namespace mds::culling {

// Per-pixel state: accumulation buffer (d, C, k) and cull buffer (d_cull, C_cull, k_cull).
// Initially both depths are MDS_CULL_DEPTH_EMPTY with C = 0, k = 0: no representative depth yet,
// OP = B(empty) * 0 = 0.
struct PixelState {
  double d = MDS_CULL_DEPTH_EMPTY;
  double C = 0.0;
  double k = 0.0;
  double d_cull = MDS_CULL_DEPTH_EMPTY;
  double C_cull = 0.0;
  double k_cull = 0.0;
};

struct AcceptanceParams {
  int mode = MDS_CULL_ACCEPT_NORMAL;  // MDS_CULL_ACCEPT_NORMAL / _EXACT / _RANDOM
  int n_budget = MDS_CULL_N_BUDGET_DEFAULT;
  // Extension (with exact or automatic coverage, CullSettings::coverage): a sample behind the
  // accumulation depth d moves d back to d_s when that occludes more, see extend_accumulation.
  bool extend_depth = false;
};

// Algorithm 1, lines 1-7. u: uniform random number in (0, 1] (line 2).
// Returns true when the sample was accepted (accumulation restarted at d_s).
bool update_accumulation_buffer(PixelState& px, const DensityHistogram& hist, double d_s,
                                double alpha_s, double u, const AcceptanceParams& params);

// Extension of Algorithm 1 (not in the paper), for a sample behind the accumulation depth
// (d < d_s, d not empty), which lines 12-14 ignore. The representative depth is "the farthest
// visible depth" of the covered sub-pixel area (Sect. 4.1): every area covered at <= d is
// covered at <= d_s too, and the sample adds its particle's share of the rest, so (d_s, C') with
// C' = accumulateConfidence(C, alpha_s, k) (N = D(d_min, d_s)) is as valid a pair as (d, C).
// It replaces it when it occludes more, OP(d_s, C') > OP(d, C) (Eq. 12). Without it a pixel on
// the boundary of two particles keeps the nearer one's depth and only its share of the pixel.
// Returns true when d moved.
bool extend_accumulation(PixelState& px, const DensityHistogram& hist, double d_s, double alpha_s);

// Algorithm 1, lines 8-17: one depth sample (d_s, alpha_s) of a particle in this pixel
// (with params.extend_depth, a sample behind d first takes extend_accumulation).
// accumulateConfidence uses N = D(d_min, d) of the depth being accumulated (Sect. 4.1: "the
// total number of particles with a depth <= d").
void update_depth_and_confidence(PixelState& px, const DensityHistogram& hist, double d_s,
                                 double alpha_s, double u, const AcceptanceParams& params);

// One level of the cull-buffer pyramid: depth and confidence per pixel, row-major.
struct ConfidenceLevel {
  int width = 0;
  int height = 0;
  std::vector<double> d;
  std::vector<double> C;
};

// Eq. 23, one reduction: ceil(w/2) x ceil(h/2), partial blocks at odd borders (see
// pyramid_depth / pyramid_confidence).
ConfidenceLevel reduce_confidence_level(const ConfidenceLevel& fine);

// Level 0 = base, then reductions down to 1 x 1.
std::vector<ConfidenceLevel> build_confidence_pyramid(const ConfidenceLevel& base);

}  // namespace mds::culling
