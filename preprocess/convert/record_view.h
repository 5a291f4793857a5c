// Views of the converter's particle records: the 32-byte records of pass A (spill.h), and, for
// one raw float32 input that fits the budget, the mapped input file itself (3 floats per
// particle, one type, one radius; no 32-byte copy is written). Both give a SpillRecord per
// index; the mapped input is scanned and sorted in place (input_scan.h, xyz_sort.h), and the
// build reads SortedXyzRecords, the copy of its positions that the Morton sort wrote.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "convert/spill.h"

namespace mds::convert {

struct SpillRecords {
  std::span<const SpillRecord> recs;
  std::span<const uint32_t> side = {};  // the side column (SideLayout words per record), or empty
  size_t size() const { return recs.size(); }
  const SpillRecord& operator[](size_t i) const { return recs[i]; }
  const void* address(size_t i) const { return &recs[i]; }
};

struct RawXyzRecords {
  const float* xyz = nullptr;  // 3 per particle
  size_t n = 0;
  int32_t type = 1;
  float radius = 0;
  size_t size() const { return n; }
  SpillRecord operator[](size_t i) const {
    return SpillRecord{double(xyz[3 * i]), double(xyz[3 * i + 1]), double(xyz[3 * i + 2]), type, radius};
  }
  const void* address(size_t i) const { return xyz + 3 * i; }
};

// The raw input's positions after sort_xyz_by_key (xyz_sort.h): already in Morton order, so the
// build reads them sequentially (identity permutation).
struct SortedXyzRecords {
  const float* xyz = nullptr;  // 3 per particle, sorted by key
  size_t n = 0;
  int32_t type = 1;
  float radius = 0;
  size_t size() const { return n; }
};

}  // namespace mds::convert
