// Algorithm 1 (double-buffered depth confidence updates) and the Eq. 23 pyramid of paper 000
// (Ibrahim et al. 2021), CPU reference. See confidence_buffer.h.
#include "culling/confidence_buffer.h"

#include <algorithm>

#include "culling/culling_math.h"

namespace mds::culling {

bool update_accumulation_buffer(PixelState& px, const DensityHistogram& hist, double d_s,
                                double alpha_s, double u, const AcceptanceParams& params) {
  // Line 2: P(d_s) (Sect. 4.5.2): compare restarting at d_s with the current (d, C).
  const double P =
      acceptance_probability(params.mode, params.n_budget, hist.behind(px.d), hist.behind(d_s),
                             px.C, alpha_s, hist.front(d_s), hist.total());
  if (d_s < px.d && accept_sample(u, P)) {  // line 3
    px.d = d_s;                             // line 4
    px.C = alpha_s;
    px.k = 1.0;
    return true;
  }
  px.C = accumulate_confidence(px.C, alpha_s, px.k, hist.front(px.d));  // line 6
  px.k += 1.0;
  return false;
}

bool extend_accumulation(PixelState& px, const DensityHistogram& hist, double d_s, double alpha_s) {
  if (!(d_s > px.d) || !(px.d < MDS_CULL_DEPTH_EMPTY) || !(d_s < MDS_CULL_DEPTH_EMPTY)) return false;
  const double C = accumulate_confidence(px.C, alpha_s, px.k, hist.front(d_s));
  if (!(hist.occluded(d_s, C) > hist.occluded(px.d, px.C))) return false;
  px.d = d_s;
  px.C = C;
  px.k += 1.0;
  return true;
}

void update_depth_and_confidence(PixelState& px, const DensityHistogram& hist, double d_s,
                                 double alpha_s, double u, const AcceptanceParams& params) {
  if (d_s <= px.d_cull) {  // lines 9-11
    px.C_cull = accumulate_confidence(px.C_cull, alpha_s, px.k_cull, hist.front(px.d_cull));
    px.k_cull += 1.0;
  }
  if (d_s <= px.d)
    update_accumulation_buffer(px, hist, d_s, alpha_s, u, params);  // 12-14
  else if (params.extend_depth)
    extend_accumulation(px, hist, d_s, alpha_s);
  if (hist.occluded(px.d_cull, px.C_cull) < hist.occluded(px.d, px.C)) {            // 15-17
    px.d_cull = px.d;
    px.C_cull = px.C;
    px.k_cull = px.k;
  }
}

ConfidenceLevel reduce_confidence_level(const ConfidenceLevel& fine) {
  ConfidenceLevel c;
  c.width = (fine.width + 1) / 2;
  c.height = (fine.height + 1) / 2;
  c.d.resize(static_cast<size_t>(c.width) * c.height);
  c.C.resize(c.d.size());
  for (int y = 0; y < c.height; ++y) {
    for (int x = 0; x < c.width; ++x) {
      const int x0 = 2 * x, y0 = 2 * y;
      const bool right = x0 + 1 < fine.width, below = y0 + 1 < fine.height;
      const int x1 = right ? x0 + 1 : x0, y1 = below ? y0 + 1 : y0;
      auto at = [&](const std::vector<double>& v, int xx, int yy) {
        return v[static_cast<size_t>(yy) * fine.width + xx];
      };
      const size_t o = static_cast<size_t>(y) * c.width + x;
      c.d[o] = pyramid_depth(at(fine.d, x0, y0), at(fine.d, x1, y0), at(fine.d, x0, y1),
                             at(fine.d, x1, y1), right, below);
      c.C[o] = pyramid_confidence(at(fine.C, x0, y0), at(fine.C, x1, y0), at(fine.C, x0, y1),
                                  at(fine.C, x1, y1), right, below);
    }
  }
  return c;
}

std::vector<ConfidenceLevel> build_confidence_pyramid(const ConfidenceLevel& base) {
  std::vector<ConfidenceLevel> levels{base};
  while (levels.back().width > 1 || levels.back().height > 1)
    levels.push_back(reduce_confidence_level(levels.back()));
  return levels;
}

}  // namespace mds::culling
