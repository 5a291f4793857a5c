// Sub-node occupancy for node classification (paper 000, §5 "hierarchical" node test, made
// tighter for streaming, issue 4): a node's culling box is cut into kOccupancyCells^3 = 64
// equal cells, and each of those into 2^3 sub-cells (8^3 = 512 in all); one bit per (sub-)cell
// says whether any particle sphere of the node reaches into it. The node test of
// cull_classify.comp tests only the occupied cells, refined into their occupied sub-cells where a
// cell lies in front, so a node whose box pokes into a pore in front of the visible wall -- while
// its particles sit behind it -- can reach O before it is ever read. The store keeps the 512
// bits per node (format version 2, docs/store-format.md "Occupancy", written by the converter
// with fine_occupancy_of_quantized); the in-memory scene builds them from the decoded particles
// with OccupancyBuilder. Both are conservative: the union of the occupied cells holds every
// particle sphere of the node.
//
// Cell (i, j, k), i, j, k in [0, 4), is bit i + 4 j + 16 k of the coarse mask; it spans
// lo + (hi - lo) * [i/4, (i+1)/4] along x (the same along y, z), the arithmetic of
// classify_box in shaders/cull_classify.comp.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "culling/culling_constants.h"

namespace mds::culling {

inline constexpr int kOccupancyCells = MDS_OCCUPANCY_CELLS;  // per axis: 4^3 = 64 cells = one uint64 per node
static_assert(kOccupancyCells * kOccupancyCells * kOccupancyCells == 64, "one uint64 mask per node");
inline constexpr uint64_t kOccupancyFull = ~0ull;  // every cell occupied (the plain box test)

// The fine level: each coarse cell split 2 x 2 x 2, 8^3 = 512 cells = 64 bytes per node. Byte c
// holds the 8 sub-cells of coarse cell c; bit s = si + 2 sj + 4 sk is fine cell
// (2 i + si, 2 j + sj, 2 k + sk). Coarse cell c is occupied exactly when byte c is non-zero.
// All zero = unknown (the GPU then tests the coarse mask alone).
inline constexpr int kOccupancyFineCells = 2 * kOccupancyCells;  // per axis: 8^3 = 512 bits = 64 B per node
using FineOccupancy = std::array<uint8_t, 64>;

// Marks the fine cells of box [lo, hi] that [a, b] overlaps (the rules of occupancy_of_box).
void fine_occupancy_of_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                           const std::array<double, 3>& a, const std::array<double, 3>& b, FineOccupancy& fine);

// The coarse mask of a fine one: bit c set when byte c is non-zero.
uint64_t coarse_occupancy(std::span<const uint8_t, 64> fine);

// The fine occupancy a store node records (docs/store-format.md, "Occupancy"): the node's
// quantized centres x = center_min + q * (center_max - center_min) / 65535, each grown by r
// (the node's largest radius), in its culling box [center_min - r, center_max + r]; the same
// cells fine_occupancy_of_box marks for each sphere's box. Preconditions: qpos.size() is a
// multiple of 3, center_min <= center_max, r >= 0, all finite.
FineOccupancy fine_occupancy_of_quantized(const double center_min[3], const double center_max[3], double r,
                                          std::span<const uint16_t> qpos);

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
  void add_box(const std::array<double, 3>& a, const std::array<double, 3>& b) { fine_occupancy_of_box(lo_, hi_, a, b, fine_); }
  void add_sphere(const std::array<double, 3>& c, double r) {
    add_box({c[0] - r, c[1] - r, c[2] - r}, {c[0] + r, c[1] + r, c[2] + r});
  }
  uint64_t mask() const { return coarse_occupancy(fine_); }  // the coarse mask
  const FineOccupancy& fine() const { return fine_; }

 private:
  std::array<double, 3> lo_, hi_;
  FineOccupancy fine_{};
};

// The cell's box (the CPU mirror of the shader's cell bounds).
void occupancy_cell_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi, int cell,
                        std::array<double, 3>& cell_lo, std::array<double, 3>& cell_hi);

}  // namespace mds::culling
