// The distribution of a store's per-particle property (`mdstream info --histogram N`), as
// ParaView's Histogram filter and OVITO's Histogram modifier show it, so that a user can choose a
// --threshold: counts of the decoded values in N equal bins over the store's property range. No
// Vulkan.
#pragma once

#include <cstdint>
#include <vector>

#include "core/result.h"
#include "store/store_reader.h"

namespace mds::store {

struct PropertyDistribution {
  // Bin b holds the particles whose decoded value v (property_value) has
  // min(bins - 1, floor((v - property_min) / (property_max - property_min) * bins)) == b (all in
  // bin 0 when the range is a single value); edges: property_min + b * width, b = 0..bins.
  std::vector<uint64_t> counts;
  std::vector<double> edges;
  uint64_t nodes_read = 0;  // payloads decoded; the other nodes were counted from their histograms
};

// Every particle of `reader`'s store counted (exact). With per-node property histograms
// (kFlagPropertyHistogram) a node whose values all fall into one bin (its q_min's and q_max's
// bins agree; the value grows with q) is counted from the directory without reading its payload;
// the others are read and decoded one at a time. Errc::invalid_argument for a store without a
// property or `bins` outside 1..10000; payload errors name the node and byte.
Result<PropertyDistribution> property_distribution(const StoreReader& reader, uint32_t bins);

}  // namespace mds::store
