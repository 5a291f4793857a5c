// The simulation cell (see cell.h).
#include "core/cell.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace mds {

SimulationCell SimulationCell::box(const double lo[3], const double hi[3]) {
  SimulationCell c;
  for (int d = 0; d < 3; ++d) {
    c.origin[d] = lo[d];
    c.vectors[d][d] = hi[d] - lo[d];
  }
  return c;
}

bool SimulationCell::finite() const {
  for (int d = 0; d < 3; ++d) {
    if (!(std::abs(origin[d]) <= kMaxMagnitude)) return false;  // also NaN
    for (int k = 0; k < 3; ++k)
      if (!(std::abs(vectors[d][k]) <= kMaxMagnitude)) return false;
  }
  return true;
}

std::array<double, 3> SimulationCell::at(double f0, double f1, double f2) const {
  std::array<double, 3> p{};
  for (int k = 0; k < 3; ++k) p[k] = origin[k] + f0 * vectors[0][k] + f1 * vectors[1][k] + f2 * vectors[2][k];
  return p;
}

const std::array<std::array<int, 2>, 12>& SimulationCell::edges() {
  // Along a (corners differing in bit 0), along b (bit 1), along c (bit 2).
  static const std::array<std::array<int, 2>, 12> e = {{{0, 1}, {2, 3}, {4, 5}, {6, 7},
                                                       {0, 2}, {1, 3}, {4, 6}, {5, 7},
                                                       {0, 4}, {1, 5}, {2, 6}, {3, 7}}};
  return e;
}

void SimulationCell::bounds(double lo[3], double hi[3]) const {
  for (int k = 0; k < 3; ++k) lo[k] = hi[k] = origin[k];
  for (int i = 1; i < 8; ++i) {
    const auto p = corner(i);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], p[k]);
      hi[k] = std::max(hi[k], p[k]);
    }
  }
}

bool SimulationCell::orthogonal() const {
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k < 3; ++k)
      if (d != k && vectors[d][k] != 0.0) return false;
  return true;
}

bool SimulationCell::operator==(const SimulationCell& o) const {
  for (int d = 0; d < 3; ++d) {
    if (origin[d] != o.origin[d] || periodic[d] != o.periodic[d]) return false;
    for (int k = 0; k < 3; ++k)
      if (vectors[d][k] != o.vectors[d][k]) return false;
  }
  return true;
}

std::string describe(const SimulationCell& c) {
  auto v = [](const double* x) { return fmt::format("({:.17g}, {:.17g}, {:.17g})", x[0], x[1], x[2]); };
  return fmt::format("a={} b={} c={} origin={} pbc={} {} {}", v(c.vectors[0]), v(c.vectors[1]), v(c.vectors[2]),
                     v(c.origin), c.periodic[0] ? 'T' : 'F', c.periodic[1] ? 'T' : 'F', c.periodic[2] ? 'T' : 'F');
}

}  // namespace mds
