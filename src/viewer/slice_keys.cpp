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
  out.distance += steps * step;
  if (step > 0.0 && std::isfinite(out.distance)) {
    // Rounded to the decimal places that resolve 1/1000 of a step (1/100 of a Shift step), so
    // that the spec the viewer prints reads "0.349", not "0.34909999999999997".
    const int decimals = std::clamp(int(std::ceil(-std::log10(0.001 * step))), 0, 17);
    out.distance = std::strtod(fmt::format("{:.{}f}", out.distance, decimals).c_str(), nullptr);
  }
  if (invert) out.invert = !out.invert;
  return out;
}

std::string slice_options(const std::vector<store::Slice>& slices) {
  std::string o;
  for (const store::Slice& s : slices) o += (o.empty() ? "--slice " : " --slice ") + store::slice_spec(s);
  return o;
}

}  // namespace mds::viewer
