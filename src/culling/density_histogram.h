// Per-pixel particle density histograms (paper 000, Ibrahim et al. 2021, Sect. 4.4, Eq. 9-11)
// and the CPU reference of their construction by ray casting a regular particle-count grid.
//
// A histogram holds D(d_i, d_{i+1}) for `bins` (<= 64) equal bins from d_min to d_max along the
// pixel's view depth z (linear distance along the optical axis). Within a bin the density is
// taken as constant, so D(d_min, d) is piecewise linear in d ("linear interpolation within bins")
// and D(d_a, d_b) (Eq. 10) is a difference of two such values.
#pragma once

#include <array>
#include <vector>

#include "culling/culling_constants.h"

namespace mds::culling {

// Scalar mirror (GLSL: mds_hist_coord): continuous bin coordinate of depth d in [0, bins]:
// 0 at or before d_min, bins at or after d_max. A degenerate range (d_max <= d_min) maps d < d_min
// to 0 and everything else to bins.
double hist_coord(double d, double d_min, double d_max, int bins);

struct DensityHistogram {
  double d_min = 0.0;
  double d_max = 0.0;
  int bins = 0;  // 0 = empty pixel (ray missed the volume)
  std::array<double, MDS_CULL_HISTOGRAM_BINS> counts{};

  double total() const;                          // D(d_min, d_max)
  double front(double d) const;                  // D(d_min, d), prefix form
  double between(double d_a, double d_b) const;  // Eq. 10: D(d_a, d_b), 0 if d_b <= d_a
  double behind(double d) const;                 // Eq. 11: B(d) = D(d, d_max), suffix form
  double occluded(double d, double C) const;     // Eq. 12: OP(d, C) = B(d) C
};

// Regular grid of particle counts per cell (the particle density volume of Sect. 3.1 / 4.4);
// density = count / cell volume. Cell (i, j, k) spans origin + cell * [i, i+1] x ... .
struct DensityGrid {
  std::array<int, 3> dims{0, 0, 0};
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  std::array<double, 3> cell{1.0, 1.0, 1.0};
  std::vector<double> counts;  // x fastest: index = i + dims[0] * (j + dims[1] * k)

  double count(int i, int j, int k) const;
  double density(int i, int j, int k) const;
};

// The ray of one pixel, parameterised by view depth z: point(z) = origin + step * z.
// Perspective: origin = eye, step = dir / dot(dir, forward) (dot(step, forward) = 1).
// Orthographic: origin = the pixel centre on the camera plane, step = forward.
struct PixelRay {
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  std::array<double, 3> step{0.0, 0.0, 1.0};
  double z_near = 0.0;  // histogram starts no closer than this
  bool perspective = true;
  double focal_px = 1.0;          // perspective: focal length in pixels
  double ortho_pixel_area = 1.0;  // orthographic: world area of one pixel
  double particle_radius = 0.0;   // the footprint grown by this radius (footprint_count)
};

// Pinhole camera helper: ray through the centre of pixel (px, py) (0-based, y down) of a
// width x height image with vertical field of view fov_y (radians). right/up/forward: an
// orthonormal camera basis.
PixelRay perspective_pixel_ray(const std::array<double, 3>& eye,
                               const std::array<double, 3>& right,
                               const std::array<double, 3>& up,
                               const std::array<double, 3>& forward, double fov_y, int width,
                               int height, int px, int py);

// Eq. 9-10 by ray casting, CPU reference. Nearest-cell density (the grid stores counts per cell;
// the paper does not say which reconstruction; nearest keeps the totals exact: an orthographic
// image whose pixels tile the grid sums to the grid's particle count). The density is evaluated
// on the pixel's centre ray and taken as constant across its footprint (the footprint is far
// smaller than a voxel of the low-resolution volume). The ray is cut at every cell face and bin
// edge, and each piece integrates rho * footprint area exactly (footprint_count), so the result
// has no step-size error. d_min/d_max are the ray's entry/exit depths (entry >= z_near);
// a ray that misses the grid gives bins = 0. Pre: 1 <= bins <= MDS_CULL_HISTOGRAM_BINS.
DensityHistogram cast_density_histogram(const DensityGrid& grid, const PixelRay& ray, int bins);

}  // namespace mds::culling
