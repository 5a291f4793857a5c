#include "viewer/threshold_keys.h"

#include <cmath>

#include "viewer/slice_keys.h"  // round_to_step

namespace mds::viewer {

double threshold_step(double property_min, double property_max) {
  const double raw = (property_max - property_min) / kThresholdStepsPerRange;
  if (!(raw > 0.0) || !std::isfinite(raw)) return 0.0;
  const double unit = std::pow(10.0, std::floor(std::log10(raw)) - 1.0);  // 2 significant digits
  return std::round(raw / unit) * unit;
}

store::Threshold step_threshold(const std::optional<store::Threshold>& t, double lower_steps, double upper_steps,
                                bool invert, double property_min, double property_max) {
  store::Threshold out = t.value_or(store::Threshold{});
  const double step = threshold_step(property_min, property_max);
  if (lower_steps != 0.0) {
    const double from = std::isfinite(out.lo) ? out.lo : property_min;
    out.lo = round_to_step(from + lower_steps * step, step);
    if (out.lo > out.hi) out.lo = out.hi;
  }
  if (upper_steps != 0.0) {
    const double from = std::isfinite(out.hi) ? out.hi : property_max;
    out.hi = round_to_step(from + upper_steps * step, step);
    if (out.hi < out.lo) out.hi = out.lo;
  }
  if (invert) out.invert = !out.invert;
  return out;
}

std::string threshold_option(const store::Threshold& t) { return "--threshold " + store::threshold_spec(t); }

}  // namespace mds::viewer
