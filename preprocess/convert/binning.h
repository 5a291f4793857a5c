// External-memory partitioning of the converter (out-of-core octree construction):
// particles spilled to a temporary file are scattered into bin files by the prefix of their
// Morton key (3 bits per octree level, up to 512 bins per pass), each bin an octree cell.
// A bin that is still larger than the in-memory limit (skewed data) is scattered again by
// the next key bits, recursively. Bins come back in Morton order, so building them one
// after the other yields nodes in global Morton order. Memory: one read chunk plus one
// write buffer per bin, together at most `buffer_bytes`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include "convert/morton.h"
#include "convert/spill.h"
#include "core/result.h"

namespace mds::convert {

struct Bin {
  std::filesystem::path path;  // temporary file of SpillRecords
  uint64_t count = 0;
  uint64_t prefix = 0;         // Morton key prefix shared by all records of the bin
  int prefix_bits = 0;         // multiple of 3: the bin is the octree cell at depth prefix_bits/3
  std::filesystem::path side_path;  // temporary side column (SideLayout words per record); empty without one
  uint32_t side_words = 0;          // SideLayout::words()
};

struct PartitionOptions {
  uint64_t max_bin_records = 0;  // a bin with more records is split again
  size_t buffer_bytes = 0;       // read chunk + all bin write buffers
  int max_levels_per_pass = 3;   // 8^3 = 512 bins per pass at most
};

struct PartitionStats {
  uint64_t passes = 0;        // scatter passes (1 + one per re-split bin)
  uint64_t records_read = 0;  // records read over all passes
};

// Scatters the records of `source` (all inside the cell `prefix`/`prefix_bits`) into bins.
// `source` is removed after it was scattered. `on_records(n)` reports progress.
Result<std::vector<Bin>> partition(TempDir& tmp, const Bin& source, const MortonGrid& grid,
                                   const PartitionOptions& options, PartitionStats& stats,
                                   const std::function<void(uint64_t)>& on_records = {});

}  // namespace mds::convert
