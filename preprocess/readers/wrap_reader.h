// Positions wrapped into the periodic simulation cell (`convert --wrap`), as OVITO's "Wrap at
// periodic boundaries" and LAMMPS' own wrapped dumps: with A the matrix whose columns are the
// cell vectors a, b, c and o its origin, the fractional coordinates f = A^-1 (x - o) are taken
// modulo 1 along the periodic vectors (f - floor(f), in [0, 1)): x minus floor(f_i) times each
// periodic vector (a position already inside keeps its bits); the other coordinates are left as
// they are. In double, per particle, as the reader hands out batches, so
// every pass of the converter sees the same wrapped positions and memory stays bounded.
#pragma once

#include <memory>
#include <string>

#include "core/cell.h"
#include "core/result.h"
#include "readers/reader.h"

namespace mds {

// The inverse of the cell's vector matrix; Errc::invalid_argument naming `file` when the cell is
// flat (|det A| <= 1e-12 |a| |b| |c|) or periodic along none of its vectors.
struct CellWrap {
  SimulationCell cell;
  double inverse[3][3];  // A^-1, row-major: f_i = sum_k inverse[i][k] (x_k - o_k)
  static Result<CellWrap> make(const SimulationCell& cell, const std::string& file);
  // Wraps one point in place; false (the point unchanged) when it lies more than 2^50 cells
  // away along a vector (or a fractional coordinate is not finite), where whole-vector shifts
  // lose the position's digits. Finite input stays finite.
  bool apply(double& x, double& y, double& z) const;
};

// `inner` with every batch wrapped into its frame's cell (FrameInfo::cell). Errc::invalid_argument
// naming `file` when the frame has no cell, or the cell cannot wrap (CellWrap::make); read() is
// Errc::range naming the file and the position for a point apply() refuses.
Result<std::unique_ptr<ParticleReader>> wrap_reader(std::unique_ptr<ParticleReader> inner, const std::string& file);

}  // namespace mds
