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

namespace {

// Per axis, the fine-cell range [first(q), last(q)] of a quantized coordinate q. The arithmetic
// is cell_range's with a = x - r, b = x + r, lo = center_min - r: the fine-cell coordinate of a
// sphere box's low side is q * s - e and of its high side q * s + k. The low side is >= -1 and
// the high side is clamped to <= kF before truncating, so int(v + 1) - 1 and int(v) are
// floor(v) there. Both are non-decreasing step functions of q with values in [0, kF - 1].
struct AxisCells {
  double s = 0, e = 0, k = 0;
  bool flat = false;
  int first(uint32_t q) const {
    if (flat) return 0;
    const double f = double(q) * s;
    return std::max(int(f - e + 1.0) - 1, 0);
  }
  int last(uint32_t q) const {
    if (flat) return kOccupancyFineCells - 1;
    const double f = double(q) * s;
    return std::min(int(std::min(f + k, double(kOccupancyFineCells))), kOccupancyFineCells - 1);
  }
};

// A step function of q in [0, 65535] with values in [0, 7] as its 7 thresholds: t[c] = the
// smallest q where the value reaches c (65536 where it never does; t[0] = 0). The value at q is
// then the number of c in 1..7 with q >= t[c], found by a branchless binary search.
struct Steps {
  uint32_t t[8];
  template <class F>
  static Steps of(F value) {
    Steps st;
    st.t[0] = 0;
    for (int c = 1; c < 8; ++c) {
      uint32_t lo = st.t[c - 1], hi = 65536;  // the smallest q in [lo, hi) with value(q) >= c, else hi
      while (lo < hi) {
        const uint32_t mid = (lo + hi) / 2;
        if (value(mid) >= c) hi = mid;
        else lo = mid + 1;
      }
      st.t[c] = lo;
    }
    return st;
  }
  int operator()(uint32_t q) const {
    uint32_t i = q >= t[4] ? 4u : 0u;
    i += q >= t[i + 2] ? 2u : 0u;
    i += q >= t[i + 1] ? 1u : 0u;
    return int(i);
  }
};

// Per axis, the code first | last << 3 of every q, looked up by q's high byte: most of the 256
// buckets of 256 values of q hold no threshold of `first` or `last` (7 each), so their code is
// one table entry; the few that do are marked kMixed and searched per particle.
struct AxisTable {
  static constexpr uint8_t kMixed = 0x80;
  Steps first, last;
  uint8_t code[256];
  void build() {
    int f = 0, l = 0;  // values at the bucket's first q
    for (uint32_t b = 0; b < 256; ++b) {
      const uint32_t lo = b << 8, hi = lo + 255;
      while (f < 7 && first.t[f + 1] <= lo) ++f;
      while (l < 7 && last.t[l + 1] <= lo) ++l;
      const bool mixed = (f < 7 && first.t[f + 1] <= hi) || (l < 7 && last.t[l + 1] <= hi);
      code[b] = mixed ? kMixed : uint8_t(f | l << 3);
    }
  }
  unsigned at(uint32_t q) const {
    const uint8_t c = code[q >> 8];
    return c != kMixed ? c : unsigned(first(q)) | unsigned(last(q)) << 3;
  }
};

// For a code f | l << 3 (f <= l): the x bits f..l of a row, and the rows f..l of an 8 x 8
// slice as bytes of 0x01.
struct CodeTables {
  uint8_t xbits[64];
  uint64_t rows[64];
  constexpr CodeTables() : xbits(), rows() {
    for (unsigned c = 0; c < 64; ++c) {
      const unsigned f = c & 7, l = c >> 3;
      if (l < f) continue;
      xbits[c] = uint8_t((2u << l) - (1u << f));
      uint64_t r = 0;
      for (unsigned y = f; y <= l; ++y) r |= 1ull << (8 * y);
      rows[c] = r;
    }
  }
};
constexpr CodeTables kCodeTables;

}  // namespace

FineOccupancy fine_occupancy_of_quantized(const double center_min[3], const double center_max[3], double r,
                                          std::span<const uint16_t> qpos) {
  // The per-particle arithmetic of AxisCells is evaluated once per node, as thresholds (about
  // 300 evaluations per axis) and a table per axis over q's high byte (AxisTable); per particle
  // the cells are three table lookups (this runs for every particle of a conversion: 12 % of
  // the converter's CPU time with the arithmetic per particle, 8 % with three-compare searches
  // per side and axis). Each z-slice is a uint64 of 8 x 8 bits (x + 8 y); the
  // byte-per-coarse-cell layout is made once per node.
  constexpr int kF = kOccupancyFineCells;
  static_assert(kF == 8, "one uint8 row of x-cells per (y, z); 7 thresholds per axis");
  AxisTable axis[3];
  for (int a = 0; a < 3; ++a) {
    AxisCells ax;
    const double w = (center_max[a] - center_min[a]) + 2.0 * r;
    ax.flat = !(w > 0.0);
    if (!ax.flat) {
      const double step = (center_max[a] - center_min[a]) / 65535.0;
      ax.s = step / w * kF;
      ax.e = 1e-5 * kF;  // eps = 1e-5 w, in cells
      ax.k = (2.0 * r + 1e-5 * w) / w * kF;
    }
    axis[a].first = Steps::of([&](uint32_t q) { return ax.first(q); });
    axis[a].last = Steps::of([&](uint32_t q) { return ax.last(q); });
    axis[a].build();
  }
  // by_z[8 fz + lz]: the x-y cells of the particles whose z-cells are fz..lz (one OR per
  // particle; spread over the slices once per node).
  uint64_t by_z[kF * kF] = {};
  const size_t n = qpos.size() / 3;
  for (size_t i = 0; i < n; ++i) {
    const unsigned cx = axis[0].at(qpos[3 * i]), cy = axis[1].at(qpos[3 * i + 1]), cz = axis[2].at(qpos[3 * i + 2]);
    // x bits copied into rows fy..ly: bytes of 0x01 over those rows, times the x bits.
    by_z[kF * (cz & 7) + (cz >> 3)] |= kCodeTables.rows[cy] * kCodeTables.xbits[cx];
  }
  uint64_t slice[kF] = {};  // per z: bit x + 8 y
  for (int fz = 0; fz < kF; ++fz)
    for (int lz = fz; lz < kF; ++lz)
      for (int z = fz; z <= lz; ++z) slice[z] |= by_z[kF * fz + lz];
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
