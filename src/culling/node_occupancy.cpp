// Sub-node occupancy masks; see node_occupancy.h.
#include "culling/node_occupancy.h"

#include <algorithm>
#include <cmath>

namespace mds::culling {

uint64_t occupancy_of_box(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                          const std::array<double, 3>& a, const std::array<double, 3>& b) {
  int first[3], last[3];
  for (int ax = 0; ax < 3; ++ax) {
    const double w = hi[ax] - lo[ax];
    if (!(w > 0.0)) {  // degenerate axis: one cell layer holds everything
      first[ax] = 0;
      last[ax] = kOccupancyCells - 1;
      continue;
    }
    const double eps = 1e-5 * w;
    const double fa = (a[ax] - eps - lo[ax]) / w * kOccupancyCells;
    const double fb = (b[ax] + eps - lo[ax]) / w * kOccupancyCells;
    first[ax] = std::clamp(int(std::floor(std::max(fa, -1.0))), 0, kOccupancyCells - 1);
    last[ax] = std::clamp(int(std::floor(std::min(fb, double(kOccupancyCells) + 1.0))), 0, kOccupancyCells - 1);
  }
  uint64_t mask = 0;
  for (int k = first[2]; k <= last[2]; ++k)
    for (int j = first[1]; j <= last[1]; ++j)
      for (int i = first[0]; i <= last[0]; ++i) mask |= 1ull << (i + kOccupancyCells * (j + kOccupancyCells * k));
  return mask;
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
