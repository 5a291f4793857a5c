// Implicit-octree partition over sorted Morton keys (see octree_partition.h).
#include "convert/octree_partition.h"

#include <algorithm>
#include <bit>

#include "convert/morton.h"

namespace mds::convert {

namespace {

// Keys: a sorted std::span<const uint64_t>, or XyzMortonKeys (computed on access).
template <class Keys>
struct Partitioner {
  const Keys& keys;
  uint32_t capacity;
  std::vector<KeyRange>& out;

  void split(size_t b, size_t e, int level) {
    if (e - b <= capacity) {
      out.push_back({b, e});
      return;
    }
    if (level >= kMortonBitsPerAxis) {
      // All keys identical at full resolution: chunk in order.
      for (size_t s = b; s < e; s += capacity) out.push_back({s, std::min(e, s + capacity)});
      return;
    }
    // Child boundaries: within one cell the child bits at `level` are non-decreasing.
    size_t bounds[9];
    bounds[0] = b;
    bounds[8] = e;
    const int shift = kMortonBits - 3 * (level + 1);
    const uint64_t base = keys[b] >> (shift + 3) << 3;  // the cell's prefix, child bits 0
    if (e - b <= 64) {
      size_t i = b;
      for (uint32_t c = 1; c < 8; ++c) {
        while (i < e && (keys[i] >> shift) < base + c) ++i;
        bounds[c] = i;
      }
    } else {
      for (uint32_t c = 1; c < 8; ++c) {
        const uint64_t first_key_of_child = (base + c) << shift;
        size_t lo = bounds[c - 1], hi = e;  // lower_bound by index
        while (lo < hi) {
          const size_t mid = lo + (hi - lo) / 2;
          if (keys[mid] < first_key_of_child) lo = mid + 1;
          else hi = mid;
        }
        bounds[c] = lo;
      }
    }
    group(bounds, 0, 8, level);
  }

  // Merges the children [lo, hi) of a cell into one group when they fit, else halves the range.
  // Plain greedy runs of siblings such as {1,2,3} would span the whole parent; halves stay boxes.
  void group(const size_t bounds[9], int lo, int hi, int level) {
    const size_t b = bounds[lo], e = bounds[hi];
    if (b == e) return;
    if (e - b <= capacity) {
      out.push_back({b, e});
    } else if (hi - lo == 1) {
      split(b, e, level + 1);
    } else {
      const int mid = (lo + hi) / 2;
      group(bounds, lo, mid, level);
      group(bounds, mid, hi, level);
    }
  }
};

template <class Keys>
void partition(const Keys& keys, int start_level, uint32_t capacity, std::vector<KeyRange>& out) {
  if (keys.size() == 0 || capacity == 0) return;
  Partitioner<Keys> p{keys, capacity, out};
  p.split(0, keys.size(), std::clamp(start_level, 0, kMortonBitsPerAxis));
}

}  // namespace

void octree_partition(std::span<const uint64_t> keys, int start_level, uint32_t capacity, std::vector<KeyRange>& out) {
  partition(keys, start_level, capacity, out);
}

void octree_partition(const XyzMortonKeys& keys, int start_level, uint32_t capacity, std::vector<KeyRange>& out) {
  partition(keys, start_level, capacity, out);
}

int common_cell_level(uint64_t first, uint64_t last) {
  const uint64_t diff = first ^ last;
  if (diff == 0) return kMortonBitsPerAxis;
  const int differing_bits = int(std::bit_width(diff));  // lowest bits that may differ
  return (kMortonBits - differing_bits) / 3;
}

}  // namespace mds::convert
