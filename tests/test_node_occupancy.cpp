// Sub-node occupancy masks (src/culling/node_occupancy.h): cell indexing, conservative marking,
// degenerate axes. The store-derived masks are checked on a real converted store in
// test_streaming_render.cpp (VoxelOccupancyHoldsEveryParticle).
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

}  // namespace
