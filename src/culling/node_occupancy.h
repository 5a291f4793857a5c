// Sub-node occupancy for node classification (paper 000, §5 "hierarchical" node test, made
// tighter for streaming, issue 4): a node's culling box is cut into kOccupancyCells^3 = 64
// equal cells and one bit per cell says whether any particle sphere of the node reaches into
// it. The node test of cull_classify.comp then tests only the occupied cells, so a node whose
// box pokes into a pore in front of the visible wall -- while its particles sit behind it --
// can reach O before it is ever read. The mask needs no format change: the streaming cache
// derives it from the node's density-voxel list (resident directory), the in-memory scene from
// the decoded particles. Both are conservative: the union of the occupied cells holds every
// particle sphere of the node.
//
// Cell (i, j, k), i, j, k in [0, 4), is bit i + 4 j + 16 k; it spans
// lo + (hi - lo) * [i/4, (i+1)/4] along x (the same along y, z), the arithmetic of
// classify_box in shaders/cull_classify.comp.
#pragma once

#include <array>
#include <cstdint>

#include "culling/culling_constants.h"

namespace mds::culling {

inline constexpr int kOccupancyCells = MDS_OCCUPANCY_CELLS;  // per axis: 4^3 = 64 cells = one uint64 per node
static_assert(kOccupancyCells * kOccupancyCells * kOccupancyCells == 64, "one uint64 mask per node");
inline constexpr uint64_t kOccupancyFull = ~0ull;  // every cell occupied (the plain box test)

// Marks the cells of box [lo, hi] that the box [a, b] overlaps (touching counts; widened by a
// relative 1e-5 of the box so float cell bounds on the GPU stay conservative). Parts of [a, b]
// outside [lo, hi] are clamped to the border cells. Precondition: lo <= hi per axis.
uint64_t occupancy_of_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                          const std::array<double, 3>& a, const std::array<double, 3>& b);

// Accumulates a node's occupancy from particle spheres or from any conservative boxes.
class OccupancyBuilder {
 public:
  // The node's culling box (the one the GPU tests); lo <= hi per axis.
  OccupancyBuilder(const std::array<double, 3>& lo, const std::array<double, 3>& hi) : lo_(lo), hi_(hi) {}
  void add_box(const std::array<double, 3>& a, const std::array<double, 3>& b) { mask_ |= occupancy_of_box(lo_, hi_, a, b); }
  void add_sphere(const std::array<double, 3>& c, double r) {
    add_box({c[0] - r, c[1] - r, c[2] - r}, {c[0] + r, c[1] + r, c[2] + r});
  }
  uint64_t mask() const { return mask_; }

 private:
  std::array<double, 3> lo_, hi_;
  uint64_t mask_ = 0;
};

// The cell's box (the CPU mirror of the shader's cell bounds).
void occupancy_cell_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi, int cell,
                        std::array<double, 3>& cell_lo, std::array<double, 3>& cell_hi);

}  // namespace mds::culling
