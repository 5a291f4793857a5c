// Morton keys: bit interleaving by the classic "magic bits" spreading.
#include "convert/morton.h"

#include <algorithm>
#include <cmath>

namespace mds::convert {

namespace {

uint32_t compact(uint64_t x) {
  x &= 0x1249249249249249ull;
  x = (x ^ (x >> 2)) & 0x10c30c30c30c30c3ull;
  x = (x ^ (x >> 4)) & 0x100f00f00f00f00full;
  x = (x ^ (x >> 8)) & 0x1f0000ff0000ffull;
  x = (x ^ (x >> 16)) & 0x1f00000000ffffull;
  x = (x ^ (x >> 32)) & 0x1fffffull;
  return uint32_t(x);
}

}  // namespace

void morton_decode(uint64_t key, uint32_t& x, uint32_t& y, uint32_t& z) {
  x = compact(key);
  y = compact(key >> 1);
  z = compact(key >> 2);
}

MortonGrid::MortonGrid(const double lo[3], const double hi[3]) {
  // Cubic cells: one scale for all axes, from the largest extent, so that octree cells (nodes,
  // octree meshlets) are cubes also in elongated boxes. Cells are [lo + i*extent/2^21, ...);
  // the largest axis's hi maps to the last cell.
  double extent = 0;
  for (int a = 0; a < 3; ++a) {
    lo_[a] = lo[a];
    hi_[a] = hi[a];
    extent = std::max(extent, hi[a] - lo[a]);
  }
  for (int a = 0; a < 3; ++a) scale_[a] = extent > 0 ? double(1u << kMortonBitsPerAxis) / extent : 0.0;
}

}  // namespace mds::convert
