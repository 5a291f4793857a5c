// Per-pixel particle density histograms and their ray-cast construction (paper 000, Ibrahim et
// al. 2021, Sect. 4.4, Eq. 9-11). See density_histogram.h.
#include "culling/density_histogram.h"

#include <algorithm>
#include <cmath>

#include "culling/culling_math.h"

namespace mds::culling {

double hist_coord(double d, double d_min, double d_max, int bins) {
  if (bins <= 0) return 0.0;
  if (!(d > d_min)) return 0.0;
  if (!(d < d_max)) return static_cast<double>(bins);
  return std::clamp((d - d_min) / (d_max - d_min) * bins, 0.0, static_cast<double>(bins));
}

double DensityHistogram::total() const {
  double s = 0.0;
  for (int i = 0; i < bins; ++i) s += counts[i];
  return s;
}

double DensityHistogram::front(double d) const {
  const double u = hist_coord(d, d_min, d_max, bins);
  const int i = static_cast<int>(std::floor(u));
  double s = 0.0;
  for (int j = 0; j < std::min(i, bins); ++j) s += counts[j];
  if (i < bins) s += counts[i] * (u - i);
  return s;
}

double DensityHistogram::between(double d_a, double d_b) const {
  if (!(d_b > d_a)) return 0.0;
  return std::max(0.0, front(d_b) - front(d_a));
}

double DensityHistogram::behind(double d) const {
  // Suffix sum so that small tails stay exact next to large totals (matters in float).
  const double u = hist_coord(d, d_min, d_max, bins);
  const int i = static_cast<int>(std::floor(u));
  double s = 0.0;
  for (int j = bins - 1; j > i; --j) s += counts[j];
  if (i < bins) s += counts[i] * (1.0 - (u - i));
  return s;
}

double DensityHistogram::occluded(double d, double C) const {
  return occluded_particles(behind(d), C);
}

double DensityGrid::count(int i, int j, int k) const {
  return counts[static_cast<size_t>(i) +
                static_cast<size_t>(dims[0]) *
                    (static_cast<size_t>(j) + static_cast<size_t>(dims[1]) * k)];
}

double DensityGrid::density(int i, int j, int k) const {
  return count(i, j, k) / (cell[0] * cell[1] * cell[2]);
}

PixelRay perspective_pixel_ray(const std::array<double, 3>& eye,
                               const std::array<double, 3>& right,
                               const std::array<double, 3>& up,
                               const std::array<double, 3>& forward, double fov_y, int width,
                               int height, int px, int py) {
  PixelRay r;
  r.origin = eye;
  r.perspective = true;
  r.focal_px = 0.5 * height / std::tan(0.5 * fov_y);
  const double sx = (px + 0.5 - 0.5 * width) / r.focal_px;   // offset on the plane z = 1
  const double sy = -(py + 0.5 - 0.5 * height) / r.focal_px;  // image y points down
  for (int a = 0; a < 3; ++a) r.step[a] = forward[a] + sx * right[a] + sy * up[a];
  return r;
}

DensityHistogram cast_density_histogram(const DensityGrid& grid, const PixelRay& ray, int bins) {
  DensityHistogram h;
  bins = std::clamp(bins, 1, MDS_CULL_HISTOGRAM_BINS);
  // Slab test of point(z) against the grid box, z restricted to [z_near, inf).
  double z0 = ray.z_near, z1 = kInfinity;
  for (int a = 0; a < 3; ++a) {
    const double lo = grid.origin[a], hi = grid.origin[a] + grid.cell[a] * grid.dims[a];
    if (grid.dims[a] <= 0) return h;
    if (ray.step[a] == 0.0) {
      if (ray.origin[a] < lo || ray.origin[a] >= hi) return h;
      continue;
    }
    double ta = (lo - ray.origin[a]) / ray.step[a], tb = (hi - ray.origin[a]) / ray.step[a];
    if (ta > tb) std::swap(ta, tb);
    z0 = std::max(z0, ta);
    z1 = std::min(z1, tb);
  }
  if (!(z1 > z0)) return h;
  h.d_min = z0;
  h.d_max = z1;
  h.bins = bins;

  // Cut points: every cell face crossed and every bin edge.
  std::vector<double> cuts;
  for (int b = 0; b <= bins; ++b) cuts.push_back(b == bins ? z1 : z0 + (z1 - z0) * b / bins);
  for (int a = 0; a < 3; ++a) {
    if (ray.step[a] == 0.0) continue;
    for (int i = 0; i <= grid.dims[a]; ++i) {
      const double z = (grid.origin[a] + grid.cell[a] * i - ray.origin[a]) / ray.step[a];
      if (z > z0 && z < z1) cuts.push_back(z);
    }
  }
  std::sort(cuts.begin(), cuts.end());
  for (size_t s = 0; s + 1 < cuts.size(); ++s) {
    const double za = cuts[s], zb = cuts[s + 1];
    if (!(zb > za)) continue;
    const double zm = 0.5 * (za + zb);  // inside one cell and one bin
    int c[3];
    for (int a = 0; a < 3; ++a) {
      const double x = ray.origin[a] + ray.step[a] * zm;
      c[a] = std::clamp(static_cast<int>(std::floor((x - grid.origin[a]) / grid.cell[a])), 0,
                        grid.dims[a] - 1);
    }
    const int b = std::clamp(static_cast<int>(std::floor((zm - z0) / (z1 - z0) * bins)), 0,
                             bins - 1);
    h.counts[b] += footprint_count(grid.density(c[0], c[1], c[2]), za, zb, ray.perspective,
                                   ray.focal_px, ray.ortho_pixel_area, ray.particle_radius);
  }
  return h;
}

}  // namespace mds::culling
