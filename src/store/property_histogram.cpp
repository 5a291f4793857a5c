// Per-node property histograms; see property_histogram.h and docs/store-format.md.
#include "store/property_histogram.h"

#include <algorithm>

namespace mds::store {

PropertyHistogram make_property_histogram(std::span<const uint16_t> q) {
  PropertyHistogram h{};
  if (q.empty()) return h;
  const auto [lo, hi] = std::minmax_element(q.begin(), q.end());
  h.q_min = *lo;
  h.q_max = *hi;
  for (const uint16_t v : q) ++h.counts[property_bin(h, v)];
  return h;
}

Status check_property_histogram(const PropertyHistogram& h, uint32_t particles) {
  if (h.q_min > h.q_max) return make_error(Errc::format, "q_min {} > q_max {}", h.q_min, h.q_max);
  uint64_t sum = 0;
  for (uint32_t b = 0; b < kPropertyBins; ++b) {
    const bool holds_values = property_bin_first(h, b) < property_bin_first(h, b + 1);
    if (!holds_values && h.counts[b] != 0)
      return make_error(Errc::format, "bin {} counts {} particles but holds no value of [{}, {}]", b, h.counts[b], h.q_min,
                        h.q_max);
    sum += h.counts[b];
  }
  if (sum != particles) return make_error(Errc::format, "counts sum to {}, the node has {} particles", sum, particles);
  if (h.counts[property_bin(h, h.q_min)] == 0 || h.counts[property_bin(h, h.q_max)] == 0)
    return make_error(Errc::format, "no particle in the bin of q_min {} or of q_max {}", h.q_min, h.q_max);
  return {};
}

std::vector<uint32_t> kept_prefix_sums(std::span<const uint8_t> keep) {
  std::vector<uint32_t> prefix(size_t(kQuantMax) + 2, 0);
  for (size_t q = 0; q <= kQuantMax; ++q) prefix[q + 1] = prefix[q] + (q < keep.size() && keep[q] ? 1 : 0);
  return prefix;
}

PropertyCover property_cover(const PropertyHistogram& h, std::span<const uint32_t> prefix) {
  const uint32_t values = uint32_t(h.q_max) - h.q_min + 1;
  const uint32_t kept = prefix[size_t(h.q_max) + 1] - prefix[h.q_min];
  if (kept == 0) return {SliceCover::none, 0.0};
  if (kept == values) return {SliceCover::all, 1.0};
  double kept_particles = 0.0, particles = 0.0;
  for (uint32_t b = 0; b < kPropertyBins; ++b) {
    if (h.counts[b] == 0) continue;
    const uint32_t first = property_bin_first(h, b), end = property_bin_first(h, b + 1);
    kept_particles += double(h.counts[b]) * double(prefix[end] - prefix[first]) / double(end - first);
    particles += h.counts[b];
  }
  return {SliceCover::some, particles > 0.0 ? kept_particles / particles : 0.0};
}

}  // namespace mds::store
