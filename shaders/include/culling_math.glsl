// GLSL 460 mirror (float) of the CPU reference src/culling/culling_math.h,
// density_histogram.h and confidence_buffer.h: probabilistic occlusion culling of
// Ibrahim, Rautek, Reina, Agus, Hadwiger (IEEE TVCG 2021, paper 000), Eq. 1-23, Algorithm 1,
// Sect. 5.1 classes, and supplement A (normal approximation with a lookup table).
//
// Every function mirrors the C++ function of the same name without the mds_ prefix, 1:1 in
// arguments and result (float for double). Differences, all documented in docs/culling-math.md:
//  * the symbolic k = infinity (and n = infinity) is the finite MDS_CULL_K_INFINITE, log M for
//    N_eff = 1 (-inf in C++) is -MDS_CULL_K_INFINITE; test with mds_is_k_infinite;
//  * MDS_CULL_ACCEPT_EXACT is CPU only; here it falls back to the normal approximation;
//  * float precision: log1p/expm1 are evaluated by series near 0 (GLSL log/exp only promise an
//    absolute error of 2^-21 near 1, which would destroy log(1 - 1/N) for N > 1e6). Expected
//    relative error of the scalar results ~1e-6 for N up to 1e9; k(d_s) may differ by 1 where
//    log_M(...) is within ~1e-6 of an integer (ceil).
//
// Usage: #extension GL_GOOGLE_include_directive : require
//        #include "culling_math.glsl"   (relative to shaders/include)
// The file is written in a scalar subset that also compiles as C++ (tests/test_culling_math.cpp
// includes it with a small shim to test the float algorithms on the CPU): literals carry the f
// suffix, shared constants are wrapped in float(), inout goes through MDS_INOUT.
#ifndef MDS_CULLING_MATH_GLSL
#define MDS_CULLING_MATH_GLSL

#include "../../src/culling/culling_constants.h"
#include "../../src/culling/normal_cdf_table.h"

#ifndef MDS_INOUT
#define MDS_INOUT(T) inout T
#endif

// The normal CDF table of supplement A. A shader that evaluates the acceptance probability per
// pixel defines MDS_NORMAL_CDF_AT(i) before including this file to read the table from a buffer
// (cull_update.comp: kCullNormalCdf, the same 256 floats); otherwise it is a constant array. On
// lavapipe a dynamically indexed constant array is rebuilt for every invocation: with it the
// 1920x1080 update pass took 700-750 ms, with the buffer 65-85 (docs/culling-math.md).
#ifndef MDS_NORMAL_CDF_AT
#ifdef MDS_GLSL_AS_CPP
const float MDS_NORMAL_CDF[MDS_CULL_NORMAL_TABLE_SIZE] = {MDS_CULL_NORMAL_CDF_TABLE_VALUES};
#else
const float MDS_NORMAL_CDF[MDS_CULL_NORMAL_TABLE_SIZE] =
    float[MDS_CULL_NORMAL_TABLE_SIZE](MDS_CULL_NORMAL_CDF_TABLE_VALUES);
#endif
#define MDS_NORMAL_CDF_AT(i) MDS_NORMAL_CDF[i]
#endif

const float MDS_PI = 3.14159265358979f;
const float MDS_SQRT2 = 1.41421356237310f;

// ---- float-stable helpers ----------------------------------------------------------------------

// log(1 + x), x >= -1 (x = -1 is the caller's special case). |x| < 0.5: 2 atanh(s),
// s = x / (2 + x), |s| <= 1/3, series to s^17 (truncation < 1e-9 relative).
float mds_log1p(float x) {
  if (abs(x) < 0.5f) {
    float s = x / (2.0f + x);
    float s2 = s * s;
    float p = 1.0f / 17.0f;
    p = p * s2 + 1.0f / 15.0f;
    p = p * s2 + 1.0f / 13.0f;
    p = p * s2 + 1.0f / 11.0f;
    p = p * s2 + 1.0f / 9.0f;
    p = p * s2 + 1.0f / 7.0f;
    p = p * s2 + 1.0f / 5.0f;
    p = p * s2 + 1.0f / 3.0f;
    p = p * s2 + 1.0f;
    return 2.0f * s * p;
  }
  return log(1.0f + x);  // 1 + x exact for x in [-1, -0.5] (Sterbenz)
}

// exp(y) - 1 for y <= 0 (used only there). |y| < 0.5: Taylor to y^9 (truncation < 1e-9).
float mds_expm1(float y) {
  if (abs(y) < 0.5f) {
    float p = 1.0f + y / 9.0f;
    p = 1.0f + y / 8.0f * p;
    p = 1.0f + y / 7.0f * p;
    p = 1.0f + y / 6.0f * p;
    p = 1.0f + y / 5.0f * p;
    p = 1.0f + y / 4.0f * p;
    p = 1.0f + y / 3.0f * p;
    p = 1.0f + y / 2.0f * p;
    return y * p;
  }
  return exp(y) - 1.0f;
}

float mds_clamp01(float x) { return clamp(x, 0.0f, 1.0f); }

float mds_effective_count(float N) { return max(N, 1.0f); }

float mds_log_m(float N) {
  float n = mds_effective_count(N);
  if (isinf(n)) return 0.0f;
  if (n == 1.0f) return -float(MDS_CULL_K_INFINITE);  // -inf in C++
  return mds_log1p(-1.0f / n);
}

// ---- Sect. 4.1 ----------------------------------------------------------------------------------

float mds_coverage_step(float A_prev, float a) { return A_prev + (1.0f - A_prev) * a; }  // Eq. 1

float mds_coverage(float a, float n) {  // Eq. 2, real n
  if (!(n > 0.0f) || !(a > 0.0f)) return 0.0f;
  if (a >= 1.0f) return 1.0f;
  return mds_clamp01(-mds_expm1(n * mds_log1p(-a)));
}

float mds_expected_unique_step(float E_prev, float N) {  // Eq. 3-4
  float n = mds_effective_count(N);
  if (isinf(n)) return E_prev + 1.0f;
  return E_prev + (n - E_prev) / n;
}

float mds_expected_unique(float k, float N) {  // Eq. 5
  if (!(k > 0.0f)) return 0.0f;
  float n = mds_effective_count(N);
  if (isinf(n)) return k;
  if (n == 1.0f) return 1.0f;
  return min(k, -n * mds_expm1(k * mds_log1p(-1.0f / n)));
}

float mds_expected_unique_increment(float k, float N) {  // Eq. 6: M^(k-1)
  if (!(k >= 1.0f)) return 0.0f;
  if (k == 1.0f) return 1.0f;
  float n = mds_effective_count(N);
  if (n == 1.0f) return 0.0f;
  return exp((k - 1.0f) * mds_log_m(n));
}

// ---- Sect. 4.2 ----------------------------------------------------------------------------------

float mds_confidence_constant_size(float alpha, float k, float N) {  // Eq. 7
  return mds_coverage(alpha, mds_expected_unique(k, N));
}

float mds_accumulate_confidence(float C, float alpha_s, float k, float N) {  // Eq. 8, k -> k+1
  float m = mds_expected_unique_increment(k + 1.0f, N);
  float gain = mds_coverage(alpha_s, m);
  return mds_clamp01(C + (1.0f - C) * gain);
}

float mds_effective_particle_area(float r) {  // Sect. 4.1 "Particle sizes"
  if (!(r > 0.0f)) return 0.0f;
  if (r >= MDS_SQRT2) return 1.0f;
  float r2 = r * r;
  if (r <= 1.0f) return mds_clamp01(r2 * (MDS_PI - 8.0f / 3.0f * r + 0.5f * r2));
  float s = sqrt(r2 - 1.0f);
  float v = 1.0f / 3.0f + 8.0f / 3.0f * s * s * s + 4.0f * s - 0.5f * r2 * r2 -
            (2.0f - MDS_PI) * r2 - 4.0f * r2 * acos(1.0f / r);
  return mds_clamp01(v);
}

// Sect. 4.1 "Particle sizes", exact clipping (culling_math.h disk_pixel_coverage).
float mds_chord_integral(float x, float h, float r) {
  float t = clamp(x / r, -1.0f, 1.0f);
  // asin(t) as atan(t, sqrt(1 - t^2)): lavapipe's float asin errs enough that r^2 asin, differenced
  // over a strip, put 6.5 px disks off by 6e-3 (CullParity.SamplePassMatchesCpuExactClipping).
  float c = sqrt(max(1.0f - t * t, 0.0f));
  return 0.5f * (x * r * c + r * r * atan(t, c)) - h * x;
}
float mds_disk_area_above(float x0, float x1, float h, float r) {
  if (!(h < r)) return 0.0f;
  float s = sqrt(r * r - h * h);
  return mds_chord_integral(clamp(x1, -s, s), h, r) - mds_chord_integral(clamp(x0, -s, s), h, r);
}
const float MDS_COVERAGE_LINE_RADIUS = 32.0f;  // culling_math.h kCoverageLineRadius
float mds_half_plane_pixel_coverage(float nx, float ny, float d) {
  float a = max(abs(nx), abs(ny)), b = min(abs(nx), abs(ny));
  float t = 0.5f * (a + b), u = 0.5f * (a - b);
  if (d >= t) return 1.0f;
  if (d <= -t) return 0.0f;
  if (abs(d) <= u) return 0.5f + d / a;
  float corner = (t - abs(d)) * (t - abs(d)) / (2.0f * a * b);
  return d > 0.0f ? 1.0f - corner : corner;
}
float mds_disk_pixel_coverage(float cx, float cy, float r) {
  if (!(r > 0.0f)) return 0.0f;
  float x0 = -cx, x1 = 1.0f - cx, y0 = -cy, y1 = 1.0f - cy;
  if (x1 <= -r || x0 >= r || y1 <= -r || y0 >= r) return 0.0f;
  float fx = max(-x0, x1), fy = max(-y0, y1);
  if (fx * fx + fy * fy <= r * r) return 1.0f;
  if (x0 <= -r && x1 >= r && y0 <= -r && y1 >= r) return MDS_PI * r * r;
  if (r > MDS_COVERAGE_LINE_RADIUS) {  // the circle as its tangent nearest the pixel's centre
    float dx = 0.5f - cx, dy = 0.5f - cy, l = sqrt(dx * dx + dy * dy);
    return l > 0.0f ? mds_half_plane_pixel_coverage(dx / l, dy / l, r - l) : 1.0f;
  }
  float a;
  if (y0 >= 0.0f)
    a = mds_disk_area_above(x0, x1, y0, r) - mds_disk_area_above(x0, x1, y1, r);
  else if (y1 <= 0.0f)
    a = mds_disk_area_above(x0, x1, -y1, r) - mds_disk_area_above(x0, x1, -y0, r);
  else
    a = 2.0f * mds_disk_area_above(x0, x1, 0.0f, r) - mds_disk_area_above(x0, x1, -y0, r) -
        mds_disk_area_above(x0, x1, y1, r);
  return clamp(a, 0.0f, min(MDS_PI * r * r, 1.0f));
}
const float MDS_MIXED_EXACT_BELOW_PX = 2.0f;  // culling_math.h kMixedExactBelowPx
float mds_mixed_pixel_coverage(float cx, float cy, float r) {  // culling_math.h mixed_pixel_coverage
  return r < MDS_MIXED_EXACT_BELOW_PX ? mds_disk_pixel_coverage(cx, cy, r) : mds_effective_particle_area(r);
}

// ---- Sect. 4.5 ----------------------------------------------------------------------------------

float mds_occluded_particles(float B, float C) { return B * C; }  // Eq. 12

float mds_unique_particles_needed(float B_d, float B_ds, float C, float a) {  // Eq. 13, 15
  float target = C * B_d;
  if (!(target > 0.0f)) return 0.0f;
  if (!(B_ds > target)) return float(MDS_CULL_K_INFINITE);
  float r = target / B_ds;
  if (a >= 1.0f) return 0.0f;
  if (!(a > 0.0f)) return float(MDS_CULL_K_INFINITE);
  return min(mds_log1p(-r) / mds_log1p(-a), float(MDS_CULL_K_INFINITE));
}

bool mds_is_k_infinite(float k) { return k >= float(MDS_CULL_K_INFINITE); }

float mds_samples_needed(float n, float N_front) {  // Eq. 18-20
  if (!(n > 0.0f)) return 0.0f;
  float N = mds_effective_count(N_front);
  if (mds_is_k_infinite(n) || n > float(MDS_CULL_ETA) * N) return float(MDS_CULL_K_INFINITE);
  if (N == 1.0f) return 1.0f;
  if (isinf(N)) return ceil(n);
  return ceil(mds_log1p(-n / N) / mds_log1p(-1.0f / N));
}

float mds_front_probability(float D_front, float D_total) {  // Eq. 22
  if (!(D_total > 0.0f)) return 0.0f;
  return mds_clamp01(D_front / D_total);
}

float mds_normal_cdf_table_entry(int i) {
  return MDS_NORMAL_CDF_AT(clamp(i, 0, MDS_CULL_NORMAL_TABLE_SIZE - 1));
}

float mds_normal_cdf_lookup(float z) {  // supplement A
  float zmax = float(MDS_CULL_NORMAL_TABLE_ZMAX);
  if (!(z > -zmax)) return 0.0f;
  if (z >= zmax) return 1.0f;
  float u = (z + zmax) / (2.0f * zmax) * float(MDS_CULL_NORMAL_TABLE_SIZE - 1);
  int i = min(int(floor(u)), MDS_CULL_NORMAL_TABLE_SIZE - 2);
  float t = u - float(i);
  float lo = MDS_NORMAL_CDF_AT(i), hi = MDS_NORMAL_CDF_AT(i + 1);
  return lo + (hi - lo) * t;
}

float mds_binomial_tail_normal(int n_budget, float k, float p) {  // supplement A, Eq. 24-30
  float kk = ceil(k);
  if (!(kk > 0.0f)) return 1.0f;
  if (!(kk <= float(n_budget))) return 0.0f;
  if (!(p > 0.0f)) return 0.0f;
  if (p >= 1.0f) return 1.0f;
  float N = float(n_budget);
  float mu = N * p;
  float sigma = sqrt(N * p * (1.0f - p));
  float a = (kk - float(MDS_CULL_CONTINUITY_CORRECTION) - mu) / sigma;
  return 1.0f - mds_normal_cdf_lookup(a);
}

float mds_binomial_tail(int mode, int n_budget, float k, float p) {
  if (mode == MDS_CULL_ACCEPT_RANDOM) return 0.5f;
  return mds_binomial_tail_normal(n_budget, k, p);  // MDS_CULL_ACCEPT_EXACT: CPU only
}

float mds_acceptance_probability(int mode, int n_budget, float B_d, float B_ds, float C,
                                 float alpha_s, float D_front, float D_total) {
  if (mode == MDS_CULL_ACCEPT_RANDOM) return 0.5f;
  float n = mds_unique_particles_needed(B_d, B_ds, C, alpha_s);
  float k = mds_samples_needed(n, D_front);
  if (mds_is_k_infinite(k)) return 0.0f;
  float p = mds_front_probability(D_front, D_total);
  return mds_binomial_tail(mode, n_budget, k, p);
}

bool mds_accept_sample(float u, float P) { return u <= P; }

// ---- Sect. 4.6, Eq. 23 --------------------------------------------------------------------------

float mds_pyramid_depth(float d00, float d10, float d01, float d11, bool has_right,
                        bool has_below) {
  float d = d00;
  if (has_right) d = max(d, d10);
  if (has_below) d = max(d, d01);
  if (has_right && has_below) d = max(d, d11);
  return d;
}

float mds_pyramid_confidence(float c00, float c10, float c01, float c11, bool has_right,
                             bool has_below) {
  float sum = c00;
  float n = 1.0f;
  if (has_right) { sum += c10; n += 1.0f; }
  if (has_below) { sum += c01; n += 1.0f; }
  if (has_right && has_below) { sum += c11; n += 1.0f; }
  return sum / n;
}

// ---- Sect. 5.1 ----------------------------------------------------------------------------------

int mds_classify_occlusion(int previous_class, bool depth_test_failed, float C_agg, float c_occ,
                           float c_medium) {
  int now = MDS_CULL_CLASS_P;
  if (depth_test_failed) {
    if (C_agg > c_occ) now = MDS_CULL_CLASS_O;
    else if (C_agg > c_medium) now = MDS_CULL_CLASS_M;
    else now = MDS_CULL_CLASS_L;
  }
  return max(previous_class, now);
}

// ---- Sect. 5: box depth test per texel (culling_math.h) ---------------------------------------

float mds_texel_half_diagonal(float texel_px, float z, bool perspective, float focal_px,
                              float ortho_pixel_area) {
  float pixel = perspective ? z / focal_px : sqrt(ortho_pixel_area);
  return texel_px * pixel * 0.70710678f;
}

// One slab of mds_ray_box_entry: narrows [t0, t1] to the ray's interval in [l, h] on one axis;
// false when the ray runs parallel to the slab outside it.
bool mds_ray_slab(float o, float dir, float l, float h, MDS_INOUT(float) t0, MDS_INOUT(float) t1) {
  if (dir == 0.0f) return o >= l && o <= h;
  float ta = (l - o) / dir, tb = (h - o) / dir;
  t0 = max(t0, min(ta, tb));
  t1 = min(t1, max(ta, tb));
  return true;
}

// Scalar arguments (the file's C++-compatible subset): ray origin o, direction dir, box lo/hi.
float mds_ray_box_entry(float ox, float oy, float oz, float dx, float dy, float dz, float lox,
                        float loy, float loz, float hix, float hiy, float hiz, float grow,
                        float t_min) {
  float t0 = t_min, t1 = 3.0e38f;
  bool inside = mds_ray_slab(ox, dx, lox - grow, hix + grow, t0, t1);
  inside = mds_ray_slab(oy, dy, loy - grow, hiy + grow, t0, t1) && inside;
  inside = mds_ray_slab(oz, dz, loz - grow, hiz + grow, t0, t1) && inside;
  return inside && t0 <= t1 ? t0 : float(MDS_CULL_DEPTH_EMPTY);
}

// ---- Sect. 4.4, Eq. 9-11 ------------------------------------------------------------------------

float mds_footprint_area(float z, bool perspective, float focal_px, float ortho_pixel_area, float radius) {
  float w = perspective ? z / focal_px : sqrt(ortho_pixel_area);
  return w * w + 4.0f * w * radius + MDS_PI * radius * radius;
}

float mds_footprint_count(float rho, float z_a, float z_b, bool perspective, float focal_px,
                          float ortho_pixel_area, float radius) {
  float dz = z_b - z_a;
  float disk = MDS_PI * radius * radius;
  if (!perspective) return rho * dz * (ortho_pixel_area + 4.0f * sqrt(ortho_pixel_area) * radius + disk);
  return rho * dz *
         ((z_b * z_b + z_a * z_b + z_a * z_a) / (3.0f * focal_px * focal_px) + 2.0f * radius * (z_a + z_b) / focal_px +
          disk);
}

float mds_hist_coord(float d, float d_min, float d_max, int bins) {
  if (bins <= 0) return 0.0f;
  if (!(d > d_min)) return 0.0f;
  if (!(d < d_max)) return float(bins);
  return clamp((d - d_min) / (d_max - d_min) * float(bins), 0.0f, float(bins));
}

float mds_hist_total(float counts[MDS_CULL_HISTOGRAM_BINS], int bins) {
  float s = 0.0f;
  for (int j = 0; j < bins; ++j) s += counts[j];
  return s;
}

float mds_hist_front(float counts[MDS_CULL_HISTOGRAM_BINS], int bins, float d_min, float d_max,
                     float d) {  // D(d_min, d)
  float u = mds_hist_coord(d, d_min, d_max, bins);
  int i = int(floor(u));
  float s = 0.0f;
  for (int j = 0; j < min(i, bins); ++j) s += counts[j];
  if (i < bins) s += counts[i] * (u - float(i));
  return s;
}

float mds_hist_between(float counts[MDS_CULL_HISTOGRAM_BINS], int bins, float d_min,
                       float d_max, float d_a, float d_b) {  // Eq. 10
  if (!(d_b > d_a)) return 0.0f;
  return max(0.0f, mds_hist_front(counts, bins, d_min, d_max, d_b) -
                       mds_hist_front(counts, bins, d_min, d_max, d_a));
}

float mds_hist_behind(float counts[MDS_CULL_HISTOGRAM_BINS], int bins, float d_min,
                      float d_max, float d) {  // Eq. 11: B(d)
  float u = mds_hist_coord(d, d_min, d_max, bins);
  int i = int(floor(u));
  float s = 0.0f;
  for (int j = bins - 1; j > i; --j) s += counts[j];
  if (i < bins) s += counts[i] * (1.0f - (u - float(i)));
  return s;
}

float mds_hist_occluded(float counts[MDS_CULL_HISTOGRAM_BINS], int bins, float d_min,
                        float d_max, float d, float C) {  // Eq. 12
  return mds_occluded_particles(mds_hist_behind(counts, bins, d_min, d_max, d), C);
}

// ---- Algorithm 1 --------------------------------------------------------------------------------

bool mds_update_accumulation_buffer(MDS_INOUT(float) d, MDS_INOUT(float) C, MDS_INOUT(float) k,
                                    float counts[MDS_CULL_HISTOGRAM_BINS], int bins,
                                    float d_min, float d_max, float d_s, float alpha_s, float u,
                                    int mode, int n_budget) {
  float P = mds_acceptance_probability(
      mode, n_budget, mds_hist_behind(counts, bins, d_min, d_max, d),
      mds_hist_behind(counts, bins, d_min, d_max, d_s), C, alpha_s,
      mds_hist_front(counts, bins, d_min, d_max, d_s), mds_hist_total(counts, bins));
  if (d_s < d && mds_accept_sample(u, P)) {
    d = d_s;
    C = alpha_s;
    k = 1.0f;
    return true;
  }
  C = mds_accumulate_confidence(C, alpha_s, k, mds_hist_front(counts, bins, d_min, d_max, d));
  k += 1.0f;
  return false;
}

// Extension (confidence_buffer.h extend_accumulation): a sample behind d moves d back to d_s
// when OP(d_s, C') > OP(d, C).
bool mds_extend_accumulation(MDS_INOUT(float) d, MDS_INOUT(float) C, MDS_INOUT(float) k,
                             float F_ds, float B_d, float B_ds, float d_s, float alpha_s) {
  if (!(d_s > d) || !(d < float(MDS_CULL_DEPTH_EMPTY)) || !(d_s < float(MDS_CULL_DEPTH_EMPTY))) return false;
  float Cx = mds_accumulate_confidence(C, alpha_s, k, F_ds);
  if (!(mds_occluded_particles(B_ds, Cx) > mds_occluded_particles(B_d, C))) return false;
  d = d_s;
  C = Cx;
  k += 1.0f;
  return true;
}

void mds_update_depth_and_confidence(MDS_INOUT(float) d, MDS_INOUT(float) C, MDS_INOUT(float) k,
                                     MDS_INOUT(float) d_cull, MDS_INOUT(float) C_cull,
                                     MDS_INOUT(float) k_cull,
                                     float counts[MDS_CULL_HISTOGRAM_BINS], int bins,
                                     float d_min, float d_max, float d_s, float alpha_s,
                                     float u, int mode, int n_budget, bool extend) {
  if (d_s <= d_cull) {
    C_cull = mds_accumulate_confidence(C_cull, alpha_s, k_cull,
                                       mds_hist_front(counts, bins, d_min, d_max, d_cull));
    k_cull += 1.0f;
  }
  if (d_s <= d)
    mds_update_accumulation_buffer(d, C, k, counts, bins, d_min, d_max, d_s, alpha_s, u, mode,
                                   n_budget);
  else if (extend)
    mds_extend_accumulation(d, C, k, mds_hist_front(counts, bins, d_min, d_max, d_s),
                            mds_hist_behind(counts, bins, d_min, d_max, d),
                            mds_hist_behind(counts, bins, d_min, d_max, d_s), d_s, alpha_s);
  if (mds_hist_occluded(counts, bins, d_min, d_max, d_cull, C_cull) <
      mds_hist_occluded(counts, bins, d_min, d_max, d, C)) {
    d_cull = d;
    C_cull = C;
    k_cull = k;
  }
}

// Algorithm 1 on precomputed front counts, O(1) per sample (cull_update.comp reads them from
// the cumulative histograms with two loads each). F_d, F_dcull, F_ds: D(d_min, x) for x = d (the
// accumulation depth before this sample), d_cull and d_s; total = D(d_min, d_max). B(x) =
// total - F(x) (Eq. 11 as the complement of Eq. 10). Same decisions as
// mds_update_depth_and_confidence up to float rounding of the sums.
void mds_update_depth_and_confidence_fronts(MDS_INOUT(float) d, MDS_INOUT(float) C,
                                            MDS_INOUT(float) k, MDS_INOUT(float) d_cull,
                                            MDS_INOUT(float) C_cull, MDS_INOUT(float) k_cull,
                                            float F_d, float F_dcull, float F_ds, float total,
                                            float d_s, float alpha_s, float u, int mode,
                                            int n_budget, bool extend) {
  if (d_s <= d_cull) {
    C_cull = mds_accumulate_confidence(C_cull, alpha_s, k_cull, F_dcull);
    k_cull += 1.0f;
  }
  float F_new = F_d;
  if (d_s <= d) {
    float P = mds_acceptance_probability(mode, n_budget, max(total - F_d, 0.0f),
                                         max(total - F_ds, 0.0f), C, alpha_s, F_ds, total);
    if (d_s < d && mds_accept_sample(u, P)) {
      d = d_s;
      C = alpha_s;
      k = 1.0f;
      F_new = F_ds;
    } else {
      C = mds_accumulate_confidence(C, alpha_s, k, F_d);
      k += 1.0f;
    }
  } else if (extend && mds_extend_accumulation(d, C, k, F_ds, max(total - F_d, 0.0f), max(total - F_ds, 0.0f), d_s,
                                               alpha_s)) {
    F_new = F_ds;
  }
  if (mds_occluded_particles(max(total - F_dcull, 0.0f), C_cull) <
      mds_occluded_particles(max(total - F_new, 0.0f), C)) {
    d_cull = d;
    C_cull = C;
    k_cull = k;
  }
}

#endif  // MDS_CULLING_MATH_GLSL
