// The distribution of a store's property; see property_distribution.h.
#include "store/property_distribution.h"

#include <algorithm>
#include <cmath>

namespace mds::store {

Result<PropertyDistribution> property_distribution(const StoreReader& reader, uint32_t bins) {
  const FileHeader& h = reader.header();
  if (!(h.flags & kFlagProperty))
    return make_error(Errc::invalid_argument, "{}: the store has no per-particle property (convert --property NAME)",
                      reader.path().string());
  if (bins < 1 || bins > 10000) return make_error(Errc::invalid_argument, "{} bins: expected 1..10000", bins);
  PropertyDistribution d;
  d.counts.assign(bins, 0);
  const double lo = h.property_min, hi = h.property_max, width = (hi - lo) / bins;
  for (uint32_t b = 0; b <= bins; ++b) d.edges.push_back(b == bins ? hi : lo + b * width);
  // The bin of every quantized value (65536 entries, 256 KiB).
  std::vector<uint32_t> bin_of(size_t(kQuantMax) + 1, 0);
  if (hi > lo)
    for (uint32_t q = 0; q <= kQuantMax; ++q) {
      const double v = property_value(h.property_min, h.property_max, uint16_t(q));
      bin_of[q] = uint32_t(std::clamp(std::floor((v - lo) / (hi - lo) * bins), 0.0, double(bins - 1)));
    }
  const auto histograms = reader.property_histograms();
  NodeData node;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < reader.nodes().size(); ++i) {
    if (!histograms.empty() && bin_of[histograms[i].q_min] == bin_of[histograms[i].q_max]) {
      d.counts[bin_of[histograms[i].q_min]] += reader.nodes()[i].particle_count;
      continue;
    }
    MDS_TRY(reader.read_node(i, node, scratch));
    ++d.nodes_read;
    for (const uint16_t q : node.property_q) ++d.counts[bin_of[q]];
  }
  return d;
}

}  // namespace mds::store
