// Sub-node occupancy masks; see node_occupancy.h.
#include "culling/node_occupancy.h"

#include <algorithm>
#include <cmath>

namespace mds::culling {

namespace {

// The range of cells (of `cells` per axis) that [a, b] overlaps, per axis.
void cell_range(const std::array<double, 3>& lo, const std::array<double, 3>& hi, const std::array<double, 3>& a,
                const std::array<double, 3>& b, int cells, int first[3], int last[3]) {
  for (int ax = 0; ax < 3; ++ax) {
    const double w = hi[ax] - lo[ax];
    if (!(w > 0.0)) {  // degenerate axis: one cell layer holds everything
      first[ax] = 0;
      last[ax] = cells - 1;
      continue;
    }
    const double eps = 1e-5 * w;
    const double fa = (a[ax] - eps - lo[ax]) / w * cells;
    const double fb = (b[ax] + eps - lo[ax]) / w * cells;
    first[ax] = std::clamp(int(std::floor(std::max(fa, -1.0))), 0, cells - 1);
    last[ax] = std::clamp(int(std::floor(std::min(fb, double(cells) + 1.0))), 0, cells - 1);
  }
}

}  // namespace

void fine_occupancy_of_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                           const std::array<double, 3>& a, const std::array<double, 3>& b, FineOccupancy& fine) {
  int first[3], last[3];
  cell_range(lo, hi, a, b, kOccupancyFineCells, first, last);
  for (int k = first[2]; k <= last[2]; ++k)
    for (int j = first[1]; j <= last[1]; ++j)
      for (int i = first[0]; i <= last[0]; ++i) {
        const int c = (i >> 1) + kOccupancyCells * ((j >> 1) + kOccupancyCells * (k >> 1));
        fine[c] |= uint8_t(1u << ((i & 1) + 2 * (j & 1) + 4 * (k & 1)));
      }
}

uint64_t coarse_occupancy(std::span<const uint8_t, 64> fine) {
  uint64_t mask = 0;
  for (int c = 0; c < 64; ++c)
    if (fine[c] != 0) mask |= 1ull << c;
  return mask;
}

FineOccupancy fine_occupancy_of_quantized(const double center_min[3], const double center_max[3], double r,
                                          std::span<const uint16_t> qpos) {
  // Per axis, the fine-cell coordinate of a sphere box's low side is q * s - e and of its high
  // side q * s + k (cell_range's arithmetic with a = x - r, b = x + r, lo = center_min - r).
  // The low side is >= -1 and the high side is clamped to <= kF before truncating, so
  // int(v + 1) - 1 and int(v) are floor(v) there (no libm call: this runs for every particle
  // of a conversion). Each z-slice is a uint64 of 8 x 8 bits (x + 8 y), filled without
  // branches per row; the byte-per-coarse-cell layout is made once per node.
  constexpr int kF = kOccupancyFineCells;
  static_assert(kF == 8, "one uint8 row of x-cells per (y, z)");
  double s[3], e[3], k[3];
  bool flat[3];
  for (int a = 0; a < 3; ++a) {
    const double w = (center_max[a] - center_min[a]) + 2.0 * r;
    flat[a] = !(w > 0.0);
    const double step = (center_max[a] - center_min[a]) / 65535.0;
    s[a] = flat[a] ? 0.0 : step / w * kF;
    e[a] = flat[a] ? 0.0 : 1e-5 * kF;  // eps = 1e-5 w, in cells
    k[a] = flat[a] ? 0.0 : (2.0 * r + 1e-5 * w) / w * kF;
  }
  uint64_t slice[kF] = {};  // per z: bit x + 8 y
  const size_t n = qpos.size() / 3;
  for (size_t i = 0; i < n; ++i) {
    int first[3], last[3];
    for (int a = 0; a < 3; ++a) {
      const double f = double(qpos[3 * i + a]) * s[a];
      first[a] = std::max(int(f - e[a] + 1.0) - 1, 0);  // f - e >= -1
      last[a] = std::min(int(std::min(f + k[a], double(kF))), kF - 1);
      if (flat[a]) first[a] = 0, last[a] = kF - 1;
    }
    const uint64_t xbits = (2u << last[0]) - (1u << first[0]);
    // xbits copied into rows first[1]..last[1]: bytes of 0x01 over those rows, times xbits.
    const uint64_t rows = (last[1] == kF - 1 ? ~0ull : (1ull << (8 * (last[1] + 1))) - 1) & ~((1ull << (8 * first[1])) - 1);
    const uint64_t pattern = (rows & 0x0101010101010101ull) * xbits;
    for (int z = first[2]; z <= last[2]; ++z) slice[z] |= pattern;
  }
  FineOccupancy fine{};
  for (int z = 0; z < kF; ++z)
    for (int y = 0; y < kF; ++y)
      for (int x = 0; x < kF; ++x)
        if (slice[z] >> (x + 8 * y) & 1u)
          fine[(x >> 1) + kOccupancyCells * ((y >> 1) + kOccupancyCells * (z >> 1))] |=
              uint8_t(1u << ((x & 1) + 2 * (y & 1) + 4 * (z & 1)));
  return fine;
}

uint64_t occupancy_of_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                          const std::array<double, 3>& a, const std::array<double, 3>& b) {
  // The coarse cells are the fine ones halved (cell_range at 8 and at 4 cells per axis floor the
  // same values times an exact power of two), so the coarse mask is derived, not marked again.
  FineOccupancy fine{};
  fine_occupancy_of_box(lo, hi, a, b, fine);
  return coarse_occupancy(fine);
}

void occupancy_cell_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi, int cell,
                        std::array<double, 3>& cell_lo, std::array<double, 3>& cell_hi) {
  const int idx[3] = {cell % kOccupancyCells, (cell / kOccupancyCells) % kOccupancyCells,
                      cell / (kOccupancyCells * kOccupancyCells)};
  for (int ax = 0; ax < 3; ++ax) {
    const double w = (hi[ax] - lo[ax]) / kOccupancyCells;
    cell_lo[ax] = lo[ax] + w * idx[ax];
    cell_hi[ax] = idx[ax] == kOccupancyCells - 1 ? hi[ax] : lo[ax] + w * (idx[ax] + 1);
  }
}

}  // namespace mds::culling
