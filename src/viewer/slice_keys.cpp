#include "viewer/slice_keys.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

namespace mds::viewer {

double extent_along(const store::Slice& s, const double lo[3], const double hi[3]) {
  double e = 0.0;
  for (int k = 0; k < 3; ++k) e += std::abs(s.normal[k]) * (hi[k] - lo[k]);
  return e;
}

store::Slice step_slice(const store::Slice& s, double steps, bool invert, const double lo[3], const double hi[3]) {
  store::Slice out = s;
  const double step = extent_along(s, lo, hi) / kSliceStepsPerExtent;
  out.distance = round_to_step(out.distance + steps * step, step);  // 1/100 of a Shift step
  if (invert) out.invert = !out.invert;
  return out;
}

double round_to_step(double v, double step) {
  if (!(step > 0.0) || !std::isfinite(v)) return v;
  const int decimals = std::clamp(int(std::ceil(-std::log10(0.001 * step))), 0, 17);
  return std::strtod(fmt::format("{:.{}f}", v, decimals).c_str(), nullptr);
}

std::string slice_options(const std::vector<store::Slice>& slices) {
  std::string o;
  for (const store::Slice& s : slices) o += (o.empty() ? "--slice " : " --slice ") + store::slice_spec(s);
  return o;
}

}  // namespace mds::viewer
