// Meshlet quality measure (see meshlet_quality.h).
#include "convert/meshlet_quality.h"

#include <emmintrin.h>

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
  // Meshlet boxes with x and y in one SSE2 vector (the same minima and maxima as std::min/max).
  size_t at = 0;
  double sum = 0;
  const double* base = xyz.data();
  for (uint8_t s : sizes) {
    const double* p = base + 3 * size_t(order[at]);
    __m128d lo_xy = _mm_loadu_pd(p), hi_xy = lo_xy, lo_z = _mm_load_sd(p + 2), hi_z = lo_z;
    for (size_t k = at + 1; k < at + s; ++k) {
      const double* r = base + 3 * size_t(order[k]);
      const __m128d xy = _mm_loadu_pd(r), z = _mm_load_sd(r + 2);
      lo_xy = _mm_min_pd(xy, lo_xy), hi_xy = _mm_max_pd(xy, hi_xy);
      lo_z = _mm_min_sd(z, lo_z), hi_z = _mm_max_sd(z, hi_z);
    }
    alignas(16) double d[2];
    _mm_store_pd(d, _mm_sub_pd(hi_xy, lo_xy));
    const double dz = _mm_cvtsd_f64(_mm_sub_sd(hi_z, lo_z));
    sum += std::sqrt(d[0] * d[0] + d[1] * d[1] + dz * dz) / spacing;
    at += s;
  }
  q.sum_diag_over_spacing += sum;
  q.measured += sizes.size();
}

}  // namespace mds::convert
