// Morton (Z-order) keys over a global bounding box: 21 bits per axis, 63-bit keys.
// Sorting particles by key orders them along the Z-order space-filling curve, so any key
// prefix of 3*L bits is an octree cell at depth L (the node hierarchy of paper 000, §3.1,
// and the external-memory binning of the converter rely on this).
#pragma once

#include <cstddef>
#include <cstdint>

namespace mds::convert {

inline constexpr int kMortonBitsPerAxis = 21;
inline constexpr int kMortonBits = 3 * kMortonBitsPerAxis;  // 63
inline constexpr uint32_t kMortonAxisMax = (1u << kMortonBitsPerAxis) - 1;

// Spreads the low 21 bits of v to every third bit ("magic bits").
inline uint64_t morton_spread(uint32_t v) {
  uint64_t x = v & kMortonAxisMax;
  x = (x | (x << 32)) & 0x1f00000000ffffull;
  x = (x | (x << 16)) & 0x1f0000ff0000ffull;
  x = (x | (x << 8)) & 0x100f00f00f00f00full;
  x = (x | (x << 4)) & 0x10c30c30c30c30c3ull;
  x = (x | (x << 2)) & 0x1249249249249249ull;
  return x;
}
// Interleaves the low 21 bits of x, y, z: bit i of x goes to bit 3i, y to 3i+1, z to 3i+2.
inline uint64_t morton_encode(uint32_t x, uint32_t y, uint32_t z) {
  return morton_spread(x) | (morton_spread(y) << 1) | (morton_spread(z) << 2);
}
// Inverse of morton_encode.
void morton_decode(uint64_t key, uint32_t& x, uint32_t& y, uint32_t& z);

// Maps positions inside [lo, hi] to 21-bit grid coordinates per axis and to keys. The grid is
// cubic: every axis uses the scale of the largest extent (shorter axes use part of the range),
// so octree cells are cubes. Degenerate axes (hi == lo) map to 0; positions outside are clamped.
class MortonGrid {
 public:
  MortonGrid() = default;
  MortonGrid(const double lo[3], const double hi[3]);
  uint32_t cell(int axis, double v) const {
    const double c = (v - lo_[axis]) * scale_[axis];
    if (!(c > 0)) return 0;  // also NaN
    if (c >= double(kMortonAxisMax)) return kMortonAxisMax;
    return uint32_t(c);
  }
  uint64_t key(double x, double y, double z) const {
    return morton_encode(cell(0, x), cell(1, y), cell(2, z));
  }
  double lo(int axis) const { return lo_[axis]; }
  double scale(int axis) const { return scale_[axis]; }  // cells per unit length
  double hi(int axis) const { return hi_[axis]; }

 private:
  double lo_[3] = {0, 0, 0};
  double hi_[3] = {0, 0, 0};
  double scale_[3] = {0, 0, 0};
};

// The keys of float32 positions (3 per particle), computed on access: the octree partition of
// the sorted raw input (xyz_sort.h) reads a few of them per cell instead of a key array.
struct XyzMortonKeys {
  const float* xyz = nullptr;
  size_t n = 0;
  const MortonGrid* grid = nullptr;
  size_t size() const { return n; }
  uint64_t operator[](size_t i) const { return grid->key(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }
};

// The 3 bits of `key` that choose the child at octree depth `level` (0 = root's children).
inline uint32_t morton_child(uint64_t key, int level) {
  return uint32_t(key >> (kMortonBits - 3 * (level + 1))) & 7u;
}
// The first `bits` bits of the key (counting from the most significant of the 63).
inline uint64_t morton_prefix(uint64_t key, int bits) {
  return bits == 0 ? 0 : key >> (kMortonBits - bits);
}

}  // namespace mds::convert
