// CPU reference (double) of the scalar culling formulas of paper 000 (Ibrahim et al. 2021),
// Eq. 1-8, 12-23 and supplement A. See culling_math.h for the contracts and
// docs/culling-math.md for the derivations and edge cases.
#include "culling/culling_math.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <boost/math/special_functions/beta.hpp>

#include "culling/normal_cdf_table.h"

namespace mds::culling {
namespace {

constexpr double kNormalTable[] = {MDS_CULL_NORMAL_CDF_TABLE_VALUES};
static_assert(sizeof(kNormalTable) / sizeof(kNormalTable[0]) == MDS_CULL_NORMAL_TABLE_SIZE,
              "normal_cdf_table.h is stale: run src/culling/gen_normal_cdf_table.py");

double clamp01(double x) { return std::clamp(x, 0.0, 1.0); }

}  // namespace

double effective_count(double N) { return std::fmax(N, 1.0); }  // fmax(NaN, 1) = 1

double log_m(double N) {
  const double n = effective_count(N);
  if (std::isinf(n)) return 0.0;
  return std::log1p(-1.0 / n);  // N_eff = 1 -> log1p(-1) = -inf
}

// ---- Sect. 4.1 ----------------------------------------------------------------------------------

double coverage_step(double A_prev, double a) {
  // Eq. 1, A = 1. (1 - A_prev) * a >= 0, so A never decreases and never exceeds 1.
  return A_prev + (1.0 - A_prev) * a;
}

double coverage(double a, double n) {
  // Eq. 2 with real n: 1 - exp(n log(1 - a)) = -expm1(n log1p(-a)).
  if (!(n > 0.0) || !(a > 0.0)) return 0.0;  // n = 0: no particle yet; a = 0: no area
  if (a >= 1.0) return 1.0;                   // 0^n = 0 for n > 0 (avoids 0 * -inf)
  return clamp01(-std::expm1(n * std::log1p(-a)));
}

double expected_unique_step(double E_prev, double N) {
  // Eq. 4 with N -> N_eff; for N_eff = inf the increment is exactly 1.
  const double n = effective_count(N);
  if (std::isinf(n)) return E_prev + 1.0;
  return E_prev + (n - E_prev) / n;
}

double expected_unique(double k, double N) {
  // Eq. 5: (1 - M^k) / (1 - M) with 1 - M = 1/N_eff, i.e. N_eff * (1 - M^k).
  if (!(k > 0.0)) return 0.0;
  const double n = effective_count(N);
  if (std::isinf(n)) return k;  // lim_{N->inf} E(n(k)) = k
  const double lm = log_m(n);
  if (std::isinf(lm)) return 1.0;  // N_eff = 1: M = 0, one unique particle after any k >= 1
  // -expm1(k log M) = 1 - M^k without cancellation; the result is <= k up to rounding.
  return std::min(k, -n * std::expm1(k * lm));
}

double expected_unique_increment(double k, double N) {
  // Eq. 6: 1 - E(n(k-1))/N = M^(k-1) (insert Eq. 5). M^0 = 1 also for M = 0.
  if (!(k >= 1.0)) return 0.0;
  if (k == 1.0) return 1.0;
  return std::exp((k - 1.0) * log_m(N));  // exp(-inf) = 0 for N_eff = 1
}

// ---- Sect. 4.2 ----------------------------------------------------------------------------------

double confidence_constant_size(double alpha, double k, double N) {
  return coverage(alpha, expected_unique(k, N));  // Eq. 7
}

double accumulate_confidence(double C, double alpha_s, double k, double N) {
  // Eq. 8, step k -> k+1: the increment of the (k+1)-th sample is Delta E(n(k+1)) = M^k.
  const double m = expected_unique_increment(k + 1.0, N);
  const double gain = coverage(alpha_s, m);  // 1 - (1 - alpha_s)^(M^k), in [0, 1]
  return clamp01(C + (1.0 - C) * gain);
}

double effective_particle_area(double r) {
  // Expected |disk(c, r) n [0,1]^2| for c uniform in [0,1]^2
  //  = P(|X - Y| < r) for X, Y uniform in the unit square (square line picking distance CDF).
  // Density of |X - Y|: 2s(s^2 - 4s + pi) on [0,1]; 2s(4 sqrt(s^2-1) - (s^2 + 2 - pi)
  // - 4 arcsec s) on [1, sqrt 2]; integrated in closed form below.
  constexpr double pi = std::numbers::pi;
  if (!(r > 0.0)) return 0.0;
  if (r >= std::numbers::sqrt2) return 1.0;
  const double r2 = r * r;
  if (r <= 1.0) return clamp01(r2 * (pi - 8.0 / 3.0 * r + 0.5 * r2));
  const double s = std::sqrt(r2 - 1.0);
  const double v = 1.0 / 3.0 + 8.0 / 3.0 * s * s * s + 4.0 * s - 0.5 * r2 * r2 - (2.0 - pi) * r2 -
                   4.0 * r2 * std::acos(1.0 / r);
  return clamp01(v);
}

namespace {
// Integral of sqrt(r^2 - x^2) - h dx (the disk's upper half above the line y = h), an
// antiderivative on [-r, r].
double chord_integral(double x, double h, double r) {
  const double t = std::clamp(x / r, -1.0, 1.0);
  return 0.5 * (x * r * std::sqrt(std::max(1.0 - t * t, 0.0)) + r * r * std::asin(t)) - h * x;
}
// Area of the disk (origin, r) inside x0 <= x <= x1, y >= h, for h >= 0.
double disk_area_above(double x0, double x1, double h, double r) {
  if (!(h < r)) return 0.0;
  const double s = std::sqrt(r * r - h * h);  // the line y = h cuts the disk at x = +-s
  return chord_integral(std::clamp(x1, -s, s), h, r) - chord_integral(std::clamp(x0, -s, s), h, r);
}
}  // namespace

double half_plane_pixel_coverage(double nx, double ny, double d) {
  const double a = std::max(std::abs(nx), std::abs(ny)), b = std::min(std::abs(nx), std::abs(ny));
  const double t = 0.5 * (a + b), u = 0.5 * (a - b);  // the square's half extent along n; the linear part
  if (d >= t) return 1.0;
  if (d <= -t) return 0.0;
  if (std::abs(d) <= u) return 0.5 + d / a;  // the line crosses two opposite edges
  const double corner = (t - std::abs(d)) * (t - std::abs(d)) / (2.0 * a * b);  // a triangle at a corner
  return d > 0.0 ? 1.0 - corner : corner;
}

double mixed_pixel_coverage(double cx, double cy, double r) {
  return r < kMixedExactBelowPx ? disk_pixel_coverage(cx, cy, r) : effective_particle_area(r);
}

double disk_pixel_coverage(double cx, double cy, double r) {
  if (!(r > 0.0)) return 0.0;
  const double x0 = -cx, x1 = 1.0 - cx, y0 = -cy, y1 = 1.0 - cy;  // the pixel around the disk's centre
  if (x1 <= -r || x0 >= r || y1 <= -r || y0 >= r) return 0.0;  // the disk's box misses the pixel
  // The pixel inside the disk (its farthest corner within r): covered.
  const double fx = std::max(-x0, x1), fy = std::max(-y0, y1);
  if (fx * fx + fy * fy <= r * r) return 1.0;
  // The disk inside the pixel: its whole area.
  if (x0 <= -r && x1 >= r && y0 <= -r && y1 >= r) return std::numbers::pi * r * r;
  if (r > kCoverageLineRadius) {  // the circle as its tangent nearest the pixel's centre
    const double dx = 0.5 - cx, dy = 0.5 - cy, l = std::sqrt(dx * dx + dy * dy);
    return l > 0.0 ? half_plane_pixel_coverage(dx / l, dy / l, r - l) : 1.0;
  }
  // Strips above y0 minus above y1, with the part below the x axis mirrored above it.
  double a;
  if (y0 >= 0.0)
    a = disk_area_above(x0, x1, y0, r) - disk_area_above(x0, x1, y1, r);
  else if (y1 <= 0.0)
    a = disk_area_above(x0, x1, -y1, r) - disk_area_above(x0, x1, -y0, r);
  else
    a = 2.0 * disk_area_above(x0, x1, 0.0, r) - disk_area_above(x0, x1, -y0, r) - disk_area_above(x0, x1, y1, r);
  return std::clamp(a, 0.0, std::min(std::numbers::pi * r * r, 1.0));
}

// ---- Sect. 4.5 ----------------------------------------------------------------------------------

double occluded_particles(double B, double C) { return B * C; }  // Eq. 12

double unique_particles_needed(double B_d, double B_ds, double C, double a) {
  // Eq. 13: C_s > r := C B(d) / B(d_s); Eq. 15: n(d_s) = log_(1-a)(1 - r).
  const double target = C * B_d;  // OP(d, C)
  if (!(target > 0.0)) return 0.0;   // nothing occluded yet: any coverage at d_s is an improvement
  if (!(B_ds > target)) return kInfinity;  // r >= 1: OP(d_s, C_s) <= B(d_s) can never exceed it
  const double r = target / B_ds;    // in (0, 1)
  if (a >= 1.0) return 0.0;          // lim_{a->1} log1p(-r)/log1p(-a) = 0
  if (!(a > 0.0)) return kInfinity;  // coverage never grows
  return std::log1p(-r) / std::log1p(-a);
}

double samples_needed(double n, double N_front) {
  // Eq. 18-20 with N = D(d_min, d_s) -> N_eff (the incoming sample itself lies at d_s).
  if (!(n > 0.0)) return 0.0;
  const double N = effective_count(N_front);
  if (std::isinf(n) || n > MDS_CULL_ETA * N) return kInfinity;  // clamped: symbolic k = infinity
  if (N == 1.0) return 1.0;  // M = 0: E(n(1)) = 1 >= n for n <= eta
  if (std::isinf(N)) return std::ceil(n);  // M = 1: E(n(k)) = k
  // Eq. 19: ceil(log_M(1 - n/N)) = ceil(log1p(-n/N) / log1p(-1/N)); both logs < 0.
  return std::ceil(std::log1p(-n / N) / std::log1p(-1.0 / N));
}

bool is_k_infinite(double k) { return k >= MDS_CULL_K_INFINITE; }

double front_probability(double D_front, double D_total) {
  if (!(D_total > 0.0)) return 0.0;  // empty pixel: no sample can land in front
  return clamp01(D_front / D_total);  // Eq. 22
}

double binomial_tail_exact(int n_budget, double k, double p) {
  // Eq. 21. P(X >= k) for integer X equals P(X >= ceil(k)).
  const double kk = std::ceil(k);
  if (!(kk > 0.0)) return 1.0;                               // k <= 0: always reached
  if (!(kk <= static_cast<double>(n_budget))) return 0.0;    // k > N_budget or infinite
  if (!(p > 0.0)) return 0.0;                                // X = 0 < k
  if (p >= 1.0) return 1.0;                                  // X = N_budget >= k
  return boost::math::ibeta(kk, static_cast<double>(n_budget) - kk + 1.0, p);
}

double normal_cdf_table_entry(int i) {
  return kNormalTable[std::clamp(i, 0, MDS_CULL_NORMAL_TABLE_SIZE - 1)];
}

double normal_cdf_lookup(double z) {
  constexpr double zmax = MDS_CULL_NORMAL_TABLE_ZMAX;
  if (!(z > -zmax)) return 0.0;  // also NaN -> 0
  if (z >= zmax) return 1.0;
  const double u = (z + zmax) / (2.0 * zmax) * (MDS_CULL_NORMAL_TABLE_SIZE - 1);
  const int i = std::min(static_cast<int>(std::floor(u)), MDS_CULL_NORMAL_TABLE_SIZE - 2);
  const double t = u - i;
  return kNormalTable[i] + (kNormalTable[i + 1] - kNormalTable[i]) * t;
}

double binomial_tail_normal(int n_budget, double k, double p) {
  const double kk = std::ceil(k);
  if (!(kk > 0.0)) return 1.0;
  if (!(kk <= static_cast<double>(n_budget))) return 0.0;
  if (!(p > 0.0)) return 0.0;  // sigma = 0: the distribution is the point mass at 0
  if (p >= 1.0) return 1.0;    // sigma = 0: point mass at N_budget >= k
  const double N = static_cast<double>(n_budget);
  const double mu = N * p;
  const double sigma = std::sqrt(N * p * (1.0 - p));  // > 0 here
  const double a = (kk - MDS_CULL_CONTINUITY_CORRECTION - mu) / sigma;
  return 1.0 - normal_cdf_lookup(a);  // supplement Eq. 30
}

double binomial_tail(int mode, int n_budget, double k, double p) {
  switch (mode) {
    case MDS_CULL_ACCEPT_EXACT: return binomial_tail_exact(n_budget, k, p);
    case MDS_CULL_ACCEPT_RANDOM: return 0.5;
    default: return binomial_tail_normal(n_budget, k, p);
  }
}

double acceptance_probability(int mode, int n_budget, double B_d, double B_ds, double C,
                              double alpha_s, double D_front, double D_total) {
  if (mode == MDS_CULL_ACCEPT_RANDOM) return 0.5;
  const double n = unique_particles_needed(B_d, B_ds, C, alpha_s);  // Eq. 15
  const double k = samples_needed(n, D_front);                      // Eq. 18-20
  if (is_k_infinite(k)) return 0.0;                                 // Sect. 4.5: symbolic inf
  const double p = front_probability(D_front, D_total);             // Eq. 22
  return binomial_tail(mode, n_budget, k, p);                       // Eq. 21
}

bool accept_sample(double u, double P) { return u <= P; }

// ---- Sect. 4.6 ----------------------------------------------------------------------------------

double pyramid_depth(double d00, double d10, double d01, double d11, bool has_right,
                     bool has_below) {
  double d = d00;
  if (has_right) d = std::max(d, d10);
  if (has_below) d = std::max(d, d01);
  if (has_right && has_below) d = std::max(d, d11);
  return d;
}

double pyramid_confidence(double c00, double c10, double c01, double c11, bool has_right,
                          bool has_below) {
  double sum = c00;
  int n = 1;
  if (has_right) { sum += c10; ++n; }
  if (has_below) { sum += c01; ++n; }
  if (has_right && has_below) { sum += c11; ++n; }
  return sum / n;
}

// ---- Sect. 5.1 ----------------------------------------------------------------------------------

int classify_occlusion(int previous_class, bool depth_test_failed, double C_agg, double c_occ,
                       double c_medium) {
  int now = MDS_CULL_CLASS_P;
  if (depth_test_failed) {
    if (C_agg > c_occ) now = MDS_CULL_CLASS_O;
    else if (C_agg > c_medium) now = MDS_CULL_CLASS_M;
    else now = MDS_CULL_CLASS_L;
  }
  return std::max(previous_class, now);  // classes only move upward within one view
}

// ---- Sect. 5: box depth test per texel ---------------------------------------------------------

double texel_half_diagonal(double texel_px, double z, bool perspective, double focal_px, double ortho_pixel_area) {
  const double pixel = perspective ? z / focal_px : std::sqrt(ortho_pixel_area);
  return texel_px * pixel * 0.70710678118654752;
}

double ray_box_entry(const double o[3], const double dir[3], const double lo[3], const double hi[3], double grow,
                     double t_min) {
  double t0 = t_min, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const double l = lo[a] - grow, h = hi[a] + grow;
    if (dir[a] == 0.0) {
      if (o[a] < l || o[a] > h) return MDS_CULL_DEPTH_EMPTY;
      continue;
    }
    const double ta = (l - o[a]) / dir[a], tb = (h - o[a]) / dir[a];
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  return t0 <= t1 ? t0 : double(MDS_CULL_DEPTH_EMPTY);
}

// ---- Sect. 4.4 ----------------------------------------------------------------------------------

double footprint_area(double z, bool perspective, double focal_px, double ortho_pixel_area, double radius) {
  const double w = perspective ? z / focal_px : std::sqrt(ortho_pixel_area);  // pixel width at depth z
  return w * w + 4.0 * w * radius + std::numbers::pi * radius * radius;
}

double footprint_count(double rho, double z_a, double z_b, bool perspective, double focal_px,
                       double ortho_pixel_area, double radius) {
  const double dz = z_b - z_a;
  const double disk = std::numbers::pi * radius * radius;
  if (!perspective) return rho * dz * (ortho_pixel_area + 4.0 * std::sqrt(ortho_pixel_area) * radius + disk);
  // (z_b^3 - z_a^3) = dz (z_b^2 + z_a z_b + z_a^2) and (z_b^2 - z_a^2) = dz (z_a + z_b): no
  // cancellation for thin segments.
  return rho * dz *
         ((z_b * z_b + z_a * z_b + z_a * z_a) / (3.0 * focal_px * focal_px) + 2.0 * radius * (z_a + z_b) / focal_px +
          disk);
}

}  // namespace mds::culling
