// Per-node property histograms (format.h kFlagPropertyHistogram; docs/store-format.md,
// "Property histograms"): for every node the range of its quantized property values and how many
// of its particles fall into each of kPropertyBins equal parts of that range. A renderer that
// streams nodes reads them from the directory's neighbour section instead of the payloads, to
// tell which nodes a --threshold leaves out whole (never read), which it keeps whole, and what
// share of the others it keeps (their place in the GPU pool and their density counts before
// they are read; docs/streaming.md, "Thresholds"). No Vulkan.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/result.h"
#include "store/format.h"
#include "store/slice.h"

namespace mds::store {

// Bin b of a histogram holds the values q_min + ceil(b * span / kPropertyBins) ..
// q_min + ceil((b + 1) * span / kPropertyBins) - 1, span = q_max - q_min + 1: bin of q =
// (q - q_min) * kPropertyBins / span. A bin holds no value where span < kPropertyBins.
inline uint32_t property_bin(const PropertyHistogram& h, uint32_t q) {
  const uint32_t span = uint32_t(h.q_max) - h.q_min + 1;
  return uint32_t((uint64_t(q) - h.q_min) * kPropertyBins / span);
}
inline uint32_t property_bin_first(const PropertyHistogram& h, uint32_t b) {
  const uint64_t span = uint64_t(h.q_max) - h.q_min + 1;
  return uint32_t(h.q_min + (uint64_t(b) * span + kPropertyBins - 1) / kPropertyBins);
}

// The histogram of a node's property_q. Precondition: q is not empty and holds at most
// kMaxNodeParticles values (every count fits its uint16).
PropertyHistogram make_property_histogram(std::span<const uint16_t> q);

// Whether `h` can describe a node of `particles` particles: q_min <= q_max, counts summing to
// `particles`, no count in a bin that holds no value, and the bins of q_min and q_max not empty
// (they are the node's smallest and largest values). Errc::format with the reason.
Status check_property_histogram(const PropertyHistogram& h, uint32_t particles);

// Prefix sums of a keep table (threshold_table: kQuantMax + 1 entries of 0 or 1): entry q holds
// the kept values below q, kQuantMax + 2 entries, so that the kept values of [a, b] are
// prefix[b + 1] - prefix[a].
std::vector<uint32_t> kept_prefix_sums(std::span<const uint8_t> keep);

// What a keep table does to a node described by `h`: cover `none` when it keeps no value of
// [q_min, q_max] (exact: none of the node's particles), `all` when it keeps every value, `some`
// otherwise; share = the expected kept share of the node's particles (0, 1, or the bins' counts
// weighted by the kept share of each bin's values, as if a bin's particles spread evenly over
// its values). prefix: kept_prefix_sums of the table.
struct PropertyCover {
  SliceCover cover = SliceCover::all;
  double share = 1.0;
};
PropertyCover property_cover(const PropertyHistogram& h, std::span<const uint32_t> prefix);

}  // namespace mds::store
