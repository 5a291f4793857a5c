// Sub-node occupancy masks (src/culling/node_occupancy.h): cell indexing, conservative marking,
// degenerate axes, the fine level's layout and the converter's records from quantized centres.
// The stored records are checked on a real converted store in test_streaming_render.cpp
// (StoredOccupancyHoldsEveryParticle), their use by the GPU in test_cull_render.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <random>

#include "culling/node_occupancy.h"

namespace {

using mds::culling::kOccupancyFull;
using mds::culling::occupancy_cell_box;
using mds::culling::occupancy_of_box;
using mds::culling::OccupancyBuilder;
using V = std::array<double, 3>;

const V kLo{0.0, 0.0, 0.0}, kHi{4.0, 8.0, 12.0};  // cells of 1 x 2 x 3

TEST(NodeOccupancy, CellIndexIsXFastest) {
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {0.2, 0.2, 0.2}, {0.3, 0.3, 0.3}), 1ull << 0);
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {3.5, 0.2, 0.2}, {3.6, 0.3, 0.3}), 1ull << 3);
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {0.2, 2.5, 0.2}, {0.3, 2.6, 0.3}), 1ull << 4);
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {0.2, 0.2, 11.0}, {0.3, 0.3, 11.5}), 1ull << 48);
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {3.9, 7.9, 11.9}, {4.0, 8.0, 12.0}), 1ull << 63);
}

TEST(NodeOccupancy, BoxesSpanningCellsMarkEveryCellTheyTouch) {
  // x in [0.5, 1.5] touches cells 0 and 1; y, z inside cell 0.
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {0.5, 0.5, 0.5}, {1.5, 1.0, 1.0}), 0b11ull);
  // Touching a cell face counts (conservative): x up to exactly 1.0.
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {0.5, 0.5, 0.5}, {1.0, 1.0, 1.0}), 0b11ull);
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {-5, -5, -5}, {50, 50, 50}), kOccupancyFull);
  // Outside the box: clamped to the border cells.
  EXPECT_EQ(occupancy_of_box(kLo, kHi, {-3, 0.5, 0.5}, {-2, 0.6, 0.6}), 1ull << 0);
}

TEST(NodeOccupancy, DegenerateAxisKeepsEveryLayer) {
  const V lo{0, 0, 5}, hi{4, 4, 5};  // flat in z
  const uint64_t m = occupancy_of_box(lo, hi, {0.1, 0.1, 5}, {0.2, 0.2, 5});
  EXPECT_EQ(std::popcount(m), 4);  // cell (0, 0, k) for every k
  EXPECT_EQ(m, (1ull << 0) | (1ull << 16) | (1ull << 32) | (1ull << 48));
}

TEST(NodeOccupancy, CellsTileTheBoxAndHoldEveryMarkedSphere) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const V c{u(rng) * 4.0, u(rng) * 8.0, u(rng) * 12.0};
    const double r = 0.01 + 0.5 * u(rng);
    OccupancyBuilder b(kLo, kHi);
    b.add_sphere(c, r);
    const uint64_t m = b.mask();
    ASSERT_NE(m, 0u);
    // The sphere's box lies in the union of the marked cells: every one of its sample points
    // (corners and centre, clamped to the node box) is in a marked cell.
    for (int k = 0; k < 9; ++k) {
      V p = c;
      if (k < 8)
        for (int a = 0; a < 3; ++a) p[a] += ((k >> a) & 1 ? r : -r);
      bool in_marked = false;
      for (int cell = 0; cell < 64; ++cell) {
        V lo, hi;
        occupancy_cell_box(kLo, kHi, cell, lo, hi);
        bool inside = true;
        for (int a = 0; a < 3; ++a) {
          const double q = std::clamp(p[a], kLo[a], kHi[a]);
          inside = inside && q >= lo[a] && q <= hi[a];
        }
        if (inside && (m >> cell & 1)) in_marked = true;
      }
      EXPECT_TRUE(in_marked) << "trial " << trial << " point " << k;
    }
    // And cells the sphere's box does not reach stay clear: a box of width <= 1.02 covers at
    // most 3 cells of width 1 (x) and 2 of widths 2 and 3 (y, z).
    EXPECT_LE(std::popcount(m), 12) << trial;
  }
  V lo, hi;
  occupancy_cell_box(kLo, kHi, 63, lo, hi);
  EXPECT_EQ(hi, kHi);  // the last cell ends exactly at the box
  occupancy_cell_box(kLo, kHi, 0, lo, hi);
  EXPECT_EQ(lo, kLo);
}

// The fine level: byte c holds the 8 sub-cells of coarse cell c, bit si + 2 sj + 4 sk.
TEST(NodeOccupancy, FineCellsLayout) {
  using mds::culling::FineOccupancy;
  using mds::culling::fine_occupancy_of_box;
  FineOccupancy f{};
  // Box [0,4]x[0,8]x[0,12]: fine cells 0.5 x 1 x 1.5. A point-like box at (0.6, 1.2, 1.6) is
  // fine cell (1, 1, 1) = coarse cell 0, sub-cell 7.
  fine_occupancy_of_box(kLo, kHi, {0.6, 1.2, 1.6}, {0.61, 1.21, 1.61}, f);
  for (int c = 0; c < 64; ++c) EXPECT_EQ(f[c], c == 0 ? 0x80 : 0) << c;
  EXPECT_EQ(mds::culling::coarse_occupancy(f), 1ull);
  // Fine cell (7, 0, 2) = coarse cell (3, 0, 1) = 3 + 16, sub-cell (1, 0, 0) = bit 1.
  f = {};
  fine_occupancy_of_box(kLo, kHi, {3.8, 0.2, 3.2}, {3.9, 0.3, 3.3}, f);
  for (int c = 0; c < 64; ++c) EXPECT_EQ(f[c], c == 19 ? 0x02 : 0) << c;
  EXPECT_EQ(mds::culling::coarse_occupancy(f), 1ull << 19);
}

// The converter's per-node record from quantized centres holds exactly the cells of the
// spheres' boxes (at most the rounding of a cell boundary apart), flat axes included.
TEST(NodeOccupancy, QuantizedRecordMatchesTheSpheres) {
  using mds::culling::FineOccupancy;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 100; ++trial) {
    double cmin[3], cmax[3];
    for (int a = 0; a < 3; ++a) {
      cmin[a] = 100.0 * u(rng) - 50.0;
      cmax[a] = (trial % 10 == 0 && a == 2) ? cmin[a] : cmin[a] + 20.0 * u(rng);  // some flat nodes
    }
    const double r = trial % 7 == 0 ? 0.0 : 3.0 * u(rng) * u(rng);
    std::vector<uint16_t> q(3 * (1 + trial * 10));
    for (auto& v : q) v = uint16_t(rng());
    const FineOccupancy got = mds::culling::fine_occupancy_of_quantized(cmin, cmax, r, q);
    V lo, hi;
    for (int a = 0; a < 3; ++a) lo[a] = cmin[a] - r, hi[a] = cmax[a] + r;
    FineOccupancy want{};
    for (size_t i = 0; i < q.size() / 3; ++i) {
      V a, b;
      for (int ax = 0; ax < 3; ++ax) {
        const double x = cmin[ax] + double(q[3 * i + ax]) * ((cmax[ax] - cmin[ax]) / 65535.0);
        a[ax] = x - r;
        b[ax] = x + r;
      }
      mds::culling::fine_occupancy_of_box(lo, hi, a, b, want);
    }
    int got_bits = 0, want_bits = 0, extra = 0;
    for (int c = 0; c < 64; ++c) {
      EXPECT_EQ(want[c] & ~got[c], 0) << "trial " << trial << " cell " << c << ": a sphere's cell is missing";
      got_bits += std::popcount(unsigned(got[c]));
      want_bits += std::popcount(unsigned(want[c]));
      extra += std::popcount(unsigned(got[c] & ~want[c]));
    }
    EXPECT_LE(extra, 2) << "trial " << trial;
    EXPECT_GT(got_bits, 0);
    EXPECT_EQ(mds::culling::coarse_occupancy(got) & ~mds::culling::coarse_occupancy(want), 0u) << trial;
  }
}

// The converter's record evaluates the cell arithmetic once per node as thresholds; it must
// give exactly the cells of evaluating it per particle (the store's bytes depend on it). Every
// quantized value on every axis, random nodes, flat axes and r = 0 included.
using FineOccupancyRef = mds::culling::FineOccupancy;

FineOccupancyRef per_particle_reference(const double cmin[3], const double cmax[3], double r,
                                        const std::vector<uint16_t>& q) {
  constexpr int kF = mds::culling::kOccupancyFineCells;
  FineOccupancyRef fine{};
  for (size_t i = 0; i < q.size() / 3; ++i) {
    int first[3], last[3];
    for (int a = 0; a < 3; ++a) {
      const double w = (cmax[a] - cmin[a]) + 2.0 * r;
      if (!(w > 0.0)) {
        first[a] = 0, last[a] = kF - 1;
        continue;
      }
      const double f = double(q[3 * i + a]) * ((cmax[a] - cmin[a]) / 65535.0 / w * kF);
      first[a] = std::max(int(f - 1e-5 * kF + 1.0) - 1, 0);
      last[a] = std::min(int(std::min(f + (2.0 * r + 1e-5 * w) / w * kF, double(kF))), kF - 1);
    }
    for (int z = first[2]; z <= last[2]; ++z)
      for (int y = first[1]; y <= last[1]; ++y)
        for (int x = first[0]; x <= last[0]; ++x)
          fine[(x >> 1) + 4 * ((y >> 1) + 4 * (z >> 1))] |= uint8_t(1u << ((x & 1) + 2 * (y & 1) + 4 * (z & 1)));
  }
  return fine;
}

TEST(NodeOccupancy, QuantizedRecordEqualsThePerParticleArithmetic) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 60; ++trial) {
    double cmin[3], cmax[3];
    for (int a = 0; a < 3; ++a) {
      cmin[a] = 1000.0 * u(rng) - 500.0;
      const double scale = trial % 3 == 0 ? 1e-3 : (trial % 3 == 1 ? 1.0 : 1e3);
      cmax[a] = (trial % 8 == 0 && a == 1) ? cmin[a] : cmin[a] + scale * u(rng);
    }
    const double r = trial % 5 == 0 ? 0.0 : (trial % 5 == 1 ? 1e-6 : 2.0 * u(rng));
    std::vector<uint16_t> q;
    if (trial < 6) {
      // Every value on every axis, in three orders.
      for (uint32_t v = 0; v < 65536; ++v) {
        q.push_back(uint16_t(v));
        q.push_back(uint16_t(trial % 2 ? 65535 - v : v));
        q.push_back(uint16_t(v * 40503u));
      }
    } else {
      // A few particles: the cells are not all set, so a wrong one shows.
      q.resize(3 * (1 + trial % 9));
      for (auto& v : q) v = uint16_t(trial % 4 == 0 ? (rng() % 2 ? 0 : 65535) : rng());
    }
    const auto got = mds::culling::fine_occupancy_of_quantized(cmin, cmax, r, q);
    const auto want = per_particle_reference(cmin, cmax, r, q);
    for (int c = 0; c < 64; ++c) ASSERT_EQ(got[c], want[c]) << "trial " << trial << " cell " << c;
  }
}

}  // namespace
