// Positional quantization in each node's local frame (paper 002, §3.3 "Quantization":
// coordinates transformed into the local frame of a cell and stored as shorts; the cell's
// origin and extent reconstruct them). Frame = the node's AABB of particle centres;
// step = extent / 65535 per axis (0 on a degenerate axis); q = round((x - min) / step).
// Decoding is x' = min + q * step exactly as store::quant_step() defines it, and the
// error |x' - x| is at most step/2 (up to double rounding).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "store/format.h"

namespace mds::convert {

struct QuantFrame {
  double min[3];
  double max[3];
  double step[3];
  double inv_step[3];       // 1 / step (0 on a degenerate axis)
  double inv_half_step[3];  // 2 / step (0 on a degenerate axis)
};

inline QuantFrame make_frame(const double lo[3], const double hi[3]) {
  QuantFrame f{};
  for (int a = 0; a < 3; ++a) {
    f.min[a] = lo[a];
    f.max[a] = hi[a];
    f.step[a] = (hi[a] - lo[a]) / double(store::kQuantMax);  // same expression as store::quant_step
    f.inv_step[a] = f.step[a] > 0 ? 1.0 / f.step[a] : 0.0;
    f.inv_half_step[a] = 2.0 * f.inv_step[a];
  }
  return f;
}

// Round to nearest (ties up) of (v - min) / step, clamped to [0, 65535]. Multiplying by the
// inverse step differs from the division by at most an ulp, so the decoding error stays at most
// half a step up to double rounding (QuantError measures it exactly).
inline uint16_t quantize(const QuantFrame& f, int axis, double v) {
  const double t = (v - f.min[axis]) * f.inv_step[axis] + 0.5;  // 0.5 on a degenerate axis -> 0
  if (!(t > 0)) return 0;
  if (t >= double(store::kQuantMax)) return uint16_t(store::kQuantMax);
  return uint16_t(t);
}

inline double dequantize(const QuantFrame& f, int axis, uint16_t q) { return f.min[axis] + double(q) * f.step[axis]; }

// Running maximum of the decoding error, absolute and relative to half a step.
struct QuantError {
  double max_abs = 0;
  double max_over_half_step = 0;

  void add(const QuantFrame& f, int axis, double v, uint16_t q) {
    const double err = std::abs(dequantize(f, axis, q) - v);
    max_abs = std::max(max_abs, err);
    max_over_half_step = std::max(max_over_half_step, err * f.inv_half_step[axis]);
  }
  void merge(const QuantError& o) {
    max_abs = std::max(max_abs, o.max_abs);
    max_over_half_step = std::max(max_over_half_step, o.max_over_half_step);
  }
};

// Per-particle radius: r = rmin + q * (rmax - rmin) / 65535.
inline uint16_t quantize_radius(float r, float rmin, float rmax) {
  if (!(rmax > rmin)) return 0;
  const double q = std::nearbyint((double(r) - rmin) / (double(rmax) - rmin) * double(store::kQuantMax));
  return uint16_t(std::clamp(q, 0.0, double(store::kQuantMax)));
}
// A per-particle property value v in [vmin, vmax] the same way (store::property_value is the
// inverse): error at most half a step, (vmax - vmin) / 131070.
inline uint16_t quantize_property(float v, float vmin, float vmax) { return quantize_radius(v, vmin, vmax); }

}  // namespace mds::convert
