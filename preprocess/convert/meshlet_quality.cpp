// Meshlet quality measure (see meshlet_quality.h).
#include "convert/meshlet_quality.h"

#include <algorithm>
#include <cmath>

namespace mds::convert {

double mean_spacing(const double lo[3], const double hi[3], uint64_t n) {
  if (n == 0) return 0;
  double volume = 1;
  int d = 0;
  for (int a = 0; a < 3; ++a) {
    const double e = hi[a] - lo[a];
    if (e > 0) {
      volume *= e;
      ++d;
    }
  }
  return d ? std::pow(volume / double(n), 1.0 / d) : 0.0;
}

void add_meshlet_quality(std::span<const double> xyz, std::span<const uint32_t> order, std::span<const uint8_t> sizes,
                         MeshletQuality& q) {
  const size_t n = xyz.size() / 3;
  if (n == 0) return;
  double lo[3] = {xyz[0], xyz[1], xyz[2]}, hi[3] = {xyz[0], xyz[1], xyz[2]};
  for (size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], xyz[3 * i + a]);
      hi[a] = std::max(hi[a], xyz[3 * i + a]);
    }
  add_meshlet_quality(xyz, order, sizes, lo, hi, q);
}

void add_meshlet_quality(std::span<const double> xyz, std::span<const uint32_t> order, std::span<const uint8_t> sizes,
                         const double node_lo[3], const double node_hi[3], MeshletQuality& q) {
  const size_t n = xyz.size() / 3;
  if (n == 0) return;
  const double spacing = mean_spacing(node_lo, node_hi, n);
  q.meshlets += sizes.size();
  q.particles += n;
  if (!(spacing > 0)) return;
  size_t at = 0;
  double sum = 0;
  for (uint8_t s : sizes) {
    const double* p = &xyz[3 * size_t(order[at])];
    double mlo[3] = {p[0], p[1], p[2]}, mhi[3] = {p[0], p[1], p[2]};
    for (size_t k = at + 1; k < at + s; ++k) {
      const double* r = &xyz[3 * size_t(order[k])];
      for (int a = 0; a < 3; ++a) {
        mlo[a] = std::min(mlo[a], r[a]);
        mhi[a] = std::max(mhi[a], r[a]);
      }
    }
    const double dx = mhi[0] - mlo[0], dy = mhi[1] - mlo[1], dz = mhi[2] - mlo[2];
    sum += std::sqrt(dx * dx + dy * dy + dz * dz) / spacing;
    at += s;
  }
  q.sum_diag_over_spacing += sum;
  q.measured += sizes.size();
}

}  // namespace mds::convert
