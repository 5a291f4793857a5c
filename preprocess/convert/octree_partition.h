// Implicit-octree partition of Morton-sorted keys (paper 000, §3.1 and §6 "Nodes"/"Meshlet
// generation"): the one implementation behind both the nodes (capacity --node-size) and the
// `octree` meshlet builder (capacity --meshlet-size).
//
// A cell with more than `capacity` keys is split into its 8 children (recursively); consecutive
// small siblings are merged while their sum stays <= capacity. Merging follows the binary halves
// of the cell (children [0,4) and [4,8), then [0,2), [2,4), ...): child indices are
// x | y<<1 | z<<2, so a merged group is still a box (half or quarter of its parent cell) and
// group bounding boxes stay compact. Groups never cross the cell the range started in, so
// partitioning each external-memory bin (a Morton-prefix cell) separately gives the same kind of
// groups as partitioning everything at once. Keys identical at full resolution are chunked in
// order. O(n) for keys in sorted order (binary searches over child boundaries per cell).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "convert/morton.h"

namespace mds::convert {

struct KeyRange {
  size_t begin;  // index into the sorted keys
  size_t end;    // one past the last
  size_t size() const { return end - begin; }
};

// `keys` sorted ascending, all inside the octree cell of depth `start_level` (they share their
// first 3*start_level bits). Appends the groups, in Morton order, to `out` (not cleared); the
// groups partition [0, keys.size()) and each holds 1..capacity keys. Indices are relative to `keys`.
void octree_partition(std::span<const uint64_t> keys, int start_level, uint32_t capacity, std::vector<KeyRange>& out);
// The same over the keys of float32 positions sorted by key (xyz_sort.h), computed on access:
// the same groups as over the array of those keys.
void octree_partition(const XyzMortonKeys& keys, int start_level, uint32_t capacity, std::vector<KeyRange>& out);

// Depth of the smallest octree cell holding both keys (sorted range: first and last key).
int common_cell_level(uint64_t first, uint64_t last);

}  // namespace mds::convert
