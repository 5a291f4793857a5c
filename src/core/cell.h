// The simulation cell (periodic box) of a data set: an origin and three edge vectors, as LAMMPS
// (orthogonal and triclinic boxes), extended XYZ (`Lattice=`, `Origin=`, `pbc=`), H5MD
// (`box/edges`, `box/offset`, `box/boundary`) and MMPLD (the data set's bounding box) describe
// it. The converter keeps it in the store (docs/store-format.md, "Cell section"), `info` reports
// it, `export` writes it back and the renderer draws its twelve edges (docs/rendering.md,
// "Simulation cell"), as OVITO's simulation cell and ParaView's outline do.
#pragma once

#include <array>
#include <string>

namespace mds {

struct SimulationCell {
  double origin[3] = {0, 0, 0};   // the corner the edge vectors start from
  double vectors[3][3] = {};      // rows: the edge vectors a, b, c (a degenerate one: a flat cell)
  bool periodic[3] = {false, false, false};  // along a, b, c

  // An axis-aligned cell [lo, hi].
  static SimulationCell box(const double lo[3], const double hi[3]);
  // Every value finite and at most kMaxMagnitude in size (float range, with room for the
  // renderer's arithmetic: a cell beyond it is not kept).
  bool finite() const;
  static constexpr double kMaxMagnitude = 1e30;
  // The point origin + f0 a + f1 b + f2 c.
  std::array<double, 3> at(double f0, double f1, double f2) const;
  // Corner k (bit 0: + a, bit 1: + b, bit 2: + c).
  std::array<double, 3> corner(int k) const { return at(k & 1, (k >> 1) & 1, (k >> 2) & 1); }
  // The twelve edges as pairs of corner indices (corner()).
  static const std::array<std::array<int, 2>, 12>& edges();
  // Its axis-aligned bounding box.
  void bounds(double lo[3], double hi[3]) const;
  // True when the vectors are diagonal (an axis-aligned box).
  bool orthogonal() const;

  bool operator==(const SimulationCell& o) const;
};

// "a=(..) b=(..) c=(..) origin=(..) pbc=T T F" with %.17g numbers, for messages.
std::string describe(const SimulationCell& cell);

}  // namespace mds
