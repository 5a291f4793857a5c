// See sample_pacer.h.
#include "render/sample_pacer.h"

#include <algorithm>
#include <cmath>

namespace mds::render {

namespace {
double median(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(mid), v.end());
  if (v.size() % 2) return v[mid];
  const double hi = v[mid];
  const double lo = *std::max_element(v.begin(), v.begin() + std::ptrdiff_t(mid));
  return 0.5 * (lo + hi);
}
}  // namespace

void SamplePacer::observe(double pass_ms) {
  if (!(pass_ms > 0.0) || !std::isfinite(pass_ms)) return;
  view_.push_back(pass_ms);
}

void SamplePacer::new_view() {
  if (view_.empty()) return;
  history_.push_back(median(view_));
  if (history_.size() > kHistory) history_.pop_front();
  view_.clear();
}

double SamplePacer::reference_ms() const {
  if (history_.size() < kMinViews) return 0.0;
  return median(std::vector<double>(history_.begin(), history_.end()));
}

uint32_t SamplePacer::passes(uint32_t full, double view_pass_ms) const {
  full = std::max(1u, full);
  const double ref = reference_ms();
  if (ref <= 0.0 || !(view_pass_ms > 0.0) || !std::isfinite(view_pass_ms)) return full;
  const double k = std::floor(double(full) * kSlack * ref / view_pass_ms);
  return uint32_t(std::clamp(k, 1.0, double(full)));
}

}  // namespace mds::render
