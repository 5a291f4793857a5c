// Nodes of the particle hierarchy (paper 000, §3.1 and §6 "Nodes"): octree cells over
// Morton keys holding at most node_size particles. A cell with more particles is split into
// its 8 children (recursively); consecutive small siblings are merged while their sum stays
// <= node_size, so nodes are not tiny. Merging follows the binary halves of the cell (children
// [0,4) and [4,8), then [0,2), [2,4), ...), so a merged node is still a box, half or quarter
// of its parent cell, and node bounding boxes stay compact. Nodes never cross the cell the range
// started in, so building each external-memory bin (a Morton-prefix cell) separately gives
// the same kind of nodes as building everything at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "convert/spill.h"

namespace mds::convert {

struct NodeRange {
  size_t begin;  // index into the sorted records
  size_t end;    // one past the last
  size_t size() const { return end - begin; }
};

// `records` sorted by key, all inside the octree cell of depth `start_level` (keys share
// their first 3*start_level bits). Returns the nodes in Morton order; they partition the range.
std::vector<NodeRange> build_nodes(std::span<const KeyedRecord> records, int start_level, uint32_t node_size);

}  // namespace mds::convert
