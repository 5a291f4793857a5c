// Nodes of the particle hierarchy (paper 000, §3.1 and §6 "Nodes"): octree cells over
// Morton keys holding at most node_size particles, built by the shared implicit-octree
// partition (octree_partition.h: recursive 8-way split, merge along binary halves). Nodes
// never cross the cell the range started in, so building each external-memory bin (a
// Morton-prefix cell) separately gives the same kind of nodes as building everything at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "convert/octree_partition.h"

namespace mds::convert {

using NodeRange = KeyRange;

// `keys` sorted, all inside the octree cell of depth `start_level` (keys share their first
// 3*start_level bits). Returns the nodes in Morton order; they partition the range.
std::vector<NodeRange> build_nodes(std::span<const uint64_t> keys, int start_level, uint32_t node_size);
// The same over sorted float32 positions (xyz_sort.h), their keys computed on access.
std::vector<NodeRange> build_nodes(const XyzMortonKeys& keys, int start_level, uint32_t node_size);

}  // namespace mds::convert
