// Node building by recursive octree subdivision over sorted Morton keys (see node_builder.h).
#include "convert/node_builder.h"

#include <algorithm>

#include "convert/morton.h"

namespace mds::convert {

namespace {

void group(std::span<const KeyedRecord> recs, const size_t bounds[9], int lo, int hi, int level,
           uint32_t node_size, std::vector<NodeRange>& out);

void split(std::span<const KeyedRecord> recs, size_t b, size_t e, int level, uint32_t node_size,
           std::vector<NodeRange>& out) {
  if (e - b <= node_size) {
    out.push_back({b, e});
    return;
  }
  if (level >= kMortonBitsPerAxis) {
    // All keys identical at full resolution: chunk in order.
    for (size_t s = b; s < e; s += node_size) out.push_back({s, std::min(e, s + node_size)});
    return;
  }
  // Child boundaries: within one cell the child bits at `level` are non-decreasing.
  size_t bounds[9];
  bounds[0] = b;
  for (uint32_t c = 1; c < 8; ++c) {
    auto first = recs.begin() + ptrdiff_t(bounds[c - 1]);
    auto it = std::partition_point(first, recs.begin() + ptrdiff_t(e),
                                   [&](const KeyedRecord& r) { return morton_child(r.key, level) < c; });
    bounds[c] = size_t(it - recs.begin());
  }
  bounds[8] = e;
  group(recs, bounds, 0, 8, level, node_size, out);
}

// Merges the children [lo, hi) of a cell into one node when they fit, else halves the range.
// Child indices are x | y<<1 | z<<2, so the halves [0,4) [4,8), then [0,2) [2,4) ..., are
// boxes: merged siblings keep a compact, box-shaped bounding box (plain greedy runs of
// siblings such as {1,2,3} would span the whole parent).
void group(std::span<const KeyedRecord> recs, const size_t bounds[9], int lo, int hi, int level,
           uint32_t node_size, std::vector<NodeRange>& out) {
  const size_t b = bounds[lo], e = bounds[hi];
  if (b == e) return;
  if (e - b <= node_size) {
    out.push_back({b, e});
  } else if (hi - lo == 1) {
    split(recs, b, e, level + 1, node_size, out);
  } else {
    const int mid = (lo + hi) / 2;
    group(recs, bounds, lo, mid, level, node_size, out);
    group(recs, bounds, mid, hi, level, node_size, out);
  }
}

}  // namespace

std::vector<NodeRange> build_nodes(std::span<const KeyedRecord> records, int start_level, uint32_t node_size) {
  std::vector<NodeRange> out;
  if (records.empty() || node_size == 0) return out;
  split(records, 0, records.size(), start_level, node_size, out);
  return out;
}

}  // namespace mds::convert
