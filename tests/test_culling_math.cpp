// Tests of the culling formulas of Ibrahim et al. 2021 (paper 000, Eq. 1-23, Algorithm 1,
// Sect. 5.1; supplement A): src/culling/culling_math.*, density_histogram.*, confidence_buffer.*,
// and the float algorithms of their GLSL mirror shaders/include/culling_math.glsl (compiled here
// as C++ through a small shim, and compiled as SPIR-V with glslangValidator).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "culling/confidence_buffer.h"
#include "culling/culling_constants.h"
#include "culling/culling_math.h"
#include "culling/density_histogram.h"

// ---- the GLSL mirror, compiled as C++ float code ------------------------------------------------
namespace glslf {
using std::acos;
using std::asin;
using std::ceil;
using std::exp;
using std::floor;
using std::log;
using std::sqrt;
inline float abs(float x) { return std::fabs(x); }
inline float min(float a, float b) { return std::min(a, b); }
inline int min(int a, int b) { return std::min(a, b); }
inline float max(float a, float b) { return std::max(a, b); }
inline int max(int a, int b) { return std::max(a, b); }
inline float clamp(float x, float lo, float hi) { return std::clamp(x, lo, hi); }
inline int clamp(int x, int lo, int hi) { return std::clamp(x, lo, hi); }
inline bool isinf(float x) { return std::isinf(x); }
#define MDS_GLSL_AS_CPP 1
#define MDS_INOUT(T) T&
#include "../shaders/include/culling_math.glsl"
#undef MDS_INOUT
}  // namespace glslf

namespace {

using namespace mds::culling;
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string run_capture(const std::string& cmd, int* rc) {
  std::string out;
  FILE* f = popen(cmd.c_str(), "r");
  if (!f) { *rc = -1; return out; }
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, f)) > 0) out.append(buf, n);
  *rc = pclose(f);
  return out;
}

std::filesystem::path temp_file(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         ("mds_culling_" + std::to_string(::getpid()) + "_" + name);
}

// ---- Sect. 4.1: Eq. 1-2 and Eq. 3-6 ------------------------------------------------------------

TEST(Coverage, ClosedFormEq2MatchesRecurrenceEq1) {
  for (double a : {1e-9, 1e-6, 1e-3, 0.1, 0.5, 0.9, 1.0 - 1e-12, 1.0}) {
    double A = 0.0;
    for (int n = 0; n <= 300; ++n) {
      const double closed = coverage(a, n);
      ASSERT_NEAR(closed, A, 1e-15 + 1e-12 * A) << "a=" << a << " n=" << n;
      A = coverage_step(A, a);
    }
  }
}

TEST(Coverage, EdgeCases) {
  EXPECT_EQ(coverage(1.0, 0.0), 0.0);  // no particle yet
  EXPECT_EQ(coverage(1.0, 1e-300), 1.0);
  EXPECT_EQ(coverage(0.0, 1e12), 0.0);
  EXPECT_NEAR(coverage(1e-9, 1.0), 1e-9, 1e-24);  // no 1 - (1 - a) cancellation
  EXPECT_NEAR(coverage(0.5, 0.5), 1.0 - std::sqrt(0.5), 1e-15);  // real n from E(n(k))
}

TEST(ExpectedUnique, ClosedFormEq5MatchesRecurrenceEq4) {
  // N < 1 and the empty pixel use N_eff = max(N, 1) in both (documented convention).
  for (double N : {0.0, 0.5, 1.0, 1.0 + 1e-9, 1.5, 2.0, 10.0, 1e3, 1e6, 1e9, 1e12, kInf}) {
    double E = 0.0, prev = 0.0;
    for (int k = 0; k <= 2000; ++k) {
      const double closed = expected_unique(k, N);
      ASSERT_NEAR(closed, E, 1e-12 * std::max(1.0, E)) << "N=" << N << " k=" << k;
      ASSERT_LE(closed, k + 1e-12);                           // E(n(k)) <= k
      ASSERT_LE(closed, effective_count(N) * (1 + 1e-15));    // at most N unique particles
      ASSERT_GE(closed, prev);                                // non-decreasing
      prev = closed;
      E = expected_unique_step(E, N);
    }
  }
  EXPECT_EQ(expected_unique(5.0, 0.0), 1.0);  // empty pixel: one particle (the sample) exists
  EXPECT_EQ(expected_unique(5.0, 0.5), 1.0);
  EXPECT_EQ(expected_unique(0.0, 0.0), 0.0);
}

TEST(ExpectedUnique, StableFormEqualsPaperFormAndLargeN) {
  // The paper's (1 - M^k)/(1 - M) with pow where that is accurate (small N).
  for (double N : {2.0, 3.0, 10.0, 100.0}) {
    const double M = 1.0 - 1.0 / N;
    for (int k = 0; k <= 200; ++k)
      ASSERT_NEAR(expected_unique(k, N), (1.0 - std::pow(M, k)) / (1.0 - M), 1e-11);
  }
  // N = 1e9 and beyond: E = k - k(k-1)/(2N) + O(k^3/N^2). Naive 1 - 1/N would lose 8 digits.
  for (double N : {1e9, 1e12, 1e15, 1e300}) {
    for (double k : {2.0, 64.0, 1000.0}) {
      const double series = k - k * (k - 1) / (2 * N) + k * (k - 1) * (k - 2) / (6 * N * N);
      ASSERT_NEAR(expected_unique(k, N), series, 1e-15 * k) << N << " " << k;
    }
  }
  EXPECT_EQ(expected_unique(64.0, kInf), 64.0);  // lim_{N->inf} E(n(k)) = k
}

TEST(ExpectedUnique, IncrementEq6) {
  for (double N : {0.0, 0.5, 1.0, 2.0, 7.5, 1e3, 1e9, 1e12, kInf}) {
    for (int k = 1; k <= 500; ++k) {
      const double inc = expected_unique_increment(k, N);
      const double diff = expected_unique(k, N) - expected_unique(k - 1, N);
      const double def = 1.0 - expected_unique(k - 1, N) / effective_count(N);
      ASSERT_NEAR(inc, diff, 1e-9) << N << " " << k;
      if (!std::isinf(N)) {
        ASSERT_NEAR(inc, def, 1e-12) << N << " " << k;
      }
      ASSERT_GE(inc, 0.0);
      ASSERT_LE(inc, 1.0);
    }
  }
}

// ---- Sect. 4.2: Eq. 7-8 ------------------------------------------------------------------------

TEST(Confidence, IncrementalEq8WithConstantSizeEqualsEq7) {
  for (double alpha : {1e-9, 1e-4, 0.01, 0.3, 0.9, 1.0}) {
    for (double N : {0.0, 0.5, 1.0, 3.0, 50.0, 1e4, 1e9, 1e12}) {
      double C = 0.0;
      for (int k = 0; k <= 400; ++k) {
        ASSERT_NEAR(C, confidence_constant_size(alpha, k, N), 1e-12)
            << "alpha=" << alpha << " N=" << N << " k=" << k;
        C = accumulate_confidence(C, alpha, k, N);  // sample k+1
      }
    }
  }
}

TEST(Confidence, IncrementalEq8VaryingSizesMatchesProduct) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (double N : {1.0, 5.0, 200.0, 1e9}) {
    double C = 0.0, log_prod = 0.0;
    for (int i = 1; i <= 300; ++i) {
      const double alpha = std::pow(U(rng), 3.0);  // many small, some large particles
      C = accumulate_confidence(C, alpha, i - 1, N);
      log_prod += expected_unique_increment(i, N) * std::log1p(-alpha);  // (1-a_i)^(n_i)
      ASSERT_NEAR(C, -std::expm1(log_prod), 1e-12) << "N=" << N << " i=" << i;
    }
  }
}

TEST(Confidence, FirstSampleGivesAlphaAndCNeverExceedsOne) {
  for (double N : {0.0, 1.0, 1e9})
    for (double a : {0.0, 1e-9, 0.25, 1.0}) EXPECT_DOUBLE_EQ(accumulate_confidence(0, a, 0, N), a);
  // C -> 1: stays exactly within [C, 1].
  for (double C : {1.0 - 1e-16, 1.0 - 1e-9, 1.0}) {
    for (double a : {1e-9, 0.5, 1.0}) {
      const double c2 = accumulate_confidence(C, a, 3, 10.0);
      EXPECT_GE(c2, C);
      EXPECT_LE(c2, 1.0);
    }
  }
}

TEST(EffectiveArea, ClosedFormMatchesMonteCarloAndLimits) {
  EXPECT_EQ(effective_particle_area(0.0), 0.0);
  EXPECT_EQ(effective_particle_area(std::numbers::sqrt2), 1.0);
  EXPECT_EQ(effective_particle_area(5.0), 1.0);
  EXPECT_NEAR(effective_particle_area(1e-4) / (std::numbers::pi * 1e-8), 1.0, 1e-3);
  // Continuity at r = 1 (the two branches) and monotonicity, alpha <= min(pi r^2, 1).
  EXPECT_NEAR(effective_particle_area(1.0 - 1e-12), effective_particle_area(1.0 + 1e-12), 1e-9);
  double prev = 0.0;
  for (int i = 1; i <= 2000; ++i) {
    const double r = 1.6 * i / 2000;
    const double a = effective_particle_area(r);
    ASSERT_GE(a, prev) << r;
    ASSERT_LE(a, std::min(std::numbers::pi * r * r, 1.0) + 1e-15) << r;
    prev = a;
  }
  // Monte Carlo of the definition: disk centre uniform in the pixel, area inside the pixel
  // = P(|X - Y| < r) for X (a point of the pixel) and Y (the centre) uniform.
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const int n = 400000;
  for (double r : {0.1, 0.3, 0.5, 0.8, 1.0, 1.1, 1.25, 1.4}) {
    int hits = 0;
    for (int i = 0; i < n; ++i) {
      const double dx = U(rng) - U(rng), dy = U(rng) - U(rng);
      hits += dx * dx + dy * dy < r * r;
    }
    const double mc = static_cast<double>(hits) / n;
    const double sigma = std::sqrt(mc * (1 - mc) / n);
    EXPECT_NEAR(effective_particle_area(r), mc, 5 * sigma + 1e-6) << "r=" << r;
  }
}

TEST(DiskPixelCoverage, KnownAreasAndLimits) {
  const double pi = std::numbers::pi;
  EXPECT_EQ(disk_pixel_coverage(0.5, 0.5, 0.0), 0.0);
  EXPECT_EQ(disk_pixel_coverage(0.5, 0.5, -1.0), 0.0);
  EXPECT_EQ(disk_pixel_coverage(0.5, 0.5, std::sqrt(0.5)), 1.0);  // the corners on the circle
  EXPECT_EQ(disk_pixel_coverage(-3.0, 0.5, 5.0), 1.0);
  EXPECT_EQ(disk_pixel_coverage(3.0, 0.5, 1.0), 0.0);              // the disk beside the pixel
  EXPECT_EQ(disk_pixel_coverage(2.0, 0.5, 1.0), 0.0);              // touching its edge
  EXPECT_NEAR(disk_pixel_coverage(0.5, 0.5, 0.25), pi / 16, 1e-15);  // inside the pixel
  EXPECT_NEAR(disk_pixel_coverage(0.5, 0.5, 0.5), pi / 4, 1e-15);    // inscribed
  EXPECT_NEAR(disk_pixel_coverage(0.0, 0.0, 1.0), pi / 4, 1e-14);    // a quarter disk
  EXPECT_NEAR(disk_pixel_coverage(0.0, 0.5, 0.3), pi * 0.09 / 2, 1e-14);  // a half disk
  EXPECT_NEAR(disk_pixel_coverage(1.0, 1.0, 1e-4), pi * 1e-8 / 4, 1e-20);  // tiny, at a corner
  // Mirror symmetry: the pixels left and right of a disk centred on their common edge.
  EXPECT_NEAR(disk_pixel_coverage(1.0, 0.5, 0.8), disk_pixel_coverage(0.0, 0.5, 0.8), 1e-15);
  // A circular segment: the disk (0.5, -0.5 + h) of radius 0.5 reaches h into the pixel; its
  // area above y = 0 is r^2 acos(1 - h/r) - (r - h) sqrt(2 r h - h^2).
  for (double h : {0.05, 0.2, 0.5, 0.8}) {
    const double r = 0.5, d = r - h;
    const double seg = r * r * std::acos(d / r) - d * std::sqrt(r * r - d * d);
    EXPECT_NEAR(disk_pixel_coverage(0.5, -0.5 + h, r), seg, 1e-14) << h;
  }
}

TEST(DiskPixelCoverage, PartitionOfUnityOverThePlane) {
  // The pixels of the plane tile it, so the coverages of one disk sum to its area pi r^2, for
  // every centre and radius: the sum over the pixels around the disk (centre in pixel units).
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  double worst = 0.0;
  for (int t = 0; t < 400; ++t) {
    const double r = std::exp(-5.0 + 7.0 * U(rng));  // 0.007 .. 7.4 px
    const double cx = 100.0 * U(rng), cy = 100.0 * U(rng);
    double sum = 0.0;
    for (int py = int(std::floor(cy - r)) - 1; py <= int(std::floor(cy + r)) + 1; ++py)
      for (int px = int(std::floor(cx - r)) - 1; px <= int(std::floor(cx + r)) + 1; ++px) {
        const double a = disk_pixel_coverage(cx - px, cy - py, r);
        ASSERT_GE(a, 0.0);
        ASSERT_LE(a, std::min(std::numbers::pi * r * r, 1.0));
        sum += a;
      }
    worst = std::max(worst, std::abs(sum / (std::numbers::pi * r * r) - 1.0));
  }
  EXPECT_LT(worst, 1e-11);
}

TEST(DiskPixelCoverage, HalfPlaneKnownAreas) {
  const double h = std::sqrt(0.5);
  EXPECT_DOUBLE_EQ(half_plane_pixel_coverage(1.0, 0.0, 0.0), 0.5);
  EXPECT_DOUBLE_EQ(half_plane_pixel_coverage(-1.0, 0.0, 0.25), 0.75);
  EXPECT_DOUBLE_EQ(half_plane_pixel_coverage(0.0, 1.0, 0.6), 1.0);
  EXPECT_DOUBLE_EQ(half_plane_pixel_coverage(0.0, -1.0, -0.6), 0.0);
  EXPECT_NEAR(half_plane_pixel_coverage(h, h, 0.0), 0.5, 1e-15);
  EXPECT_NEAR(half_plane_pixel_coverage(h, -h, -h + 0.1), 0.01, 1e-15);  // a corner triangle of legs 0.1 sqrt 2
  EXPECT_NEAR(half_plane_pixel_coverage(-h, h, h - 0.1), 0.99, 1e-15);
  // Monte Carlo over random lines.
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (int t = 0; t < 20; ++t) {
    const double ang = 2 * std::numbers::pi * U(rng), nx = std::cos(ang), ny = std::sin(ang), d = 1.6 * U(rng) - 0.8;
    int in = 0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) in += nx * (U(rng) - 0.5) + ny * (U(rng) - 0.5) <= d;
    const double mc = double(in) / n;
    EXPECT_NEAR(half_plane_pixel_coverage(nx, ny, d), mc, 5 * std::sqrt(mc * (1 - mc) / n) + 1e-6) << ang << " " << d;
  }
}

TEST(DiskPixelCoverage, LargeDisksByTheirTangentStayWithinTheBound) {
  // Above kCoverageLineRadius the circle is its tangent inside the pixel: the disk's coverages
  // still sum to pi r^2 (the tangent lies outside the arc by x^2 / 2r, about 1/(24 r) of a rim
  // pixel, times ~2 pi r rim pixels: < 1 pixel in all), and the switch at the radius is smooth.
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (double r : {32.5, 100.0, 731.0, 2000.0}) {
    const double cx = 5000.0 + U(rng), cy = 7000.0 + U(rng);
    double sum = 0.0;
    for (int py = int(std::floor(cy - r)) - 1; py <= int(std::floor(cy + r)) + 1; ++py)
      for (int px = int(std::floor(cx - r)) - 1; px <= int(std::floor(cx + r)) + 1; ++px) {
        const double a = disk_pixel_coverage(cx - px, cy - py, r);
        ASSERT_GE(a, 0.0);
        ASSERT_LE(a, 1.0);
        sum += a;
      }
    EXPECT_NEAR(sum, std::numbers::pi * r * r, 1.0) << r;
    EXPECT_GT(sum, std::numbers::pi * r * r) << r;  // the half planes contain the disk
  }
  double jump = 0.0;
  for (int t = 0; t < 2000; ++t) {
    const double ang = 2 * std::numbers::pi * U(rng), d = kCoverageLineRadius + 1.5 * U(rng) - 0.75;
    const double cx = 0.5 - d * std::cos(ang), cy = 0.5 - d * std::sin(ang);
    jump = std::max(jump, std::abs(disk_pixel_coverage(cx, cy, kCoverageLineRadius + 1e-9) -
                                   disk_pixel_coverage(cx, cy, kCoverageLineRadius)));
  }
  EXPECT_LT(jump, 0.12 / kCoverageLineRadius);
}

TEST(DiskPixelCoverage, MatchesMonteCarlo) {
  // The definition: the fraction of uniform points of the pixel inside the disk.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const int n = 200000;
  for (int t = 0; t < 12; ++t) {
    const double r = 0.1 + 1.5 * U(rng), cx = -r + (1.0 + 2.0 * r) * U(rng), cy = -r + (1.0 + 2.0 * r) * U(rng);
    int hits = 0;
    for (int i = 0; i < n; ++i) {
      const double dx = U(rng) - cx, dy = U(rng) - cy;
      hits += dx * dx + dy * dy < r * r;
    }
    const double mc = double(hits) / n, sigma = std::sqrt(mc * (1.0 - mc) / n);
    EXPECT_NEAR(disk_pixel_coverage(cx, cy, r), mc, 5.0 * sigma + 1e-6) << cx << " " << cy << " " << r;
  }
}

// ---- Sect. 4.5: Eq. 13-20 ----------------------------------------------------------------------

TEST(Threshold, UniqueParticlesEq15InvertsCoverage) {
  for (double a : {1e-6, 0.01, 0.2, 0.7}) {
    for (double C : {0.1, 0.5, 0.9, 0.999}) {
      for (double ratio : {1.0, 1.5, 10.0, 1e6}) {  // B(d_s) / B(d)
        const double B_d = 1000.0, B_ds = B_d * ratio;
        const double n = unique_particles_needed(B_d, B_ds, C, a);
        if (ratio == 1.0 && C == 1.0) continue;
        ASSERT_TRUE(std::isfinite(n));
        // At n the coverage reaches the threshold of Eq. 13: OP(d_s, C_s(n)) == OP(d, C).
        ASSERT_NEAR(occluded_particles(B_ds, coverage(a, n)), occluded_particles(B_d, C),
                    1e-9 * B_d * C)
            << a << " " << C << " " << ratio;
      }
    }
  }
  EXPECT_EQ(unique_particles_needed(100, 200, 0.0, 0.5), 0.0);   // C = 0: nothing to beat
  EXPECT_EQ(unique_particles_needed(0, 200, 0.9, 0.5), 0.0);     // B(d) = 0: OP(d, C) = 0
  EXPECT_EQ(unique_particles_needed(100, 100, 1.0, 0.5), kInf);  // r = 1: cannot be beaten
  EXPECT_EQ(unique_particles_needed(100, 0, 0.5, 0.5), kInf);    // inconsistent input, safe
  EXPECT_EQ(unique_particles_needed(100, 200, 0.5, 1.0), 0.0);   // a = 1 covers the pixel
  EXPECT_EQ(unique_particles_needed(100, 200, 0.5, 0.0), kInf);  // a = 0 never covers
  EXPECT_GT(unique_particles_needed(100, 200, 0.5, 1e-300), 1e290);
}

TEST(Threshold, SamplesNeededEq19IsMinimalAndClampsEq20) {
  for (double N : {1.5, 2.0, 10.0, 1e3, 1e6, 1e9}) {
    for (double frac : {1e-6, 0.01, 0.3, 0.5, 0.9, 0.97, 0.98}) {
      const double n = frac * N;
      const double k = samples_needed(n, N);
      ASSERT_FALSE(is_k_infinite(k)) << N << " " << frac;
      // Minimal k with E(n(k)) >= n (Eq. 16-17), up to rounding at exact integers.
      ASSERT_GE(expected_unique(k, N), n * (1 - 1e-9)) << N << " " << frac;
      ASSERT_LT(expected_unique(k - 1, N), n * (1 + 1e-9)) << N << " " << frac;
    }
    // Eq. 20: n > eta N is clamped -> symbolic infinity -> P = 0 (Sect. 4.5).
    const double k_inf = samples_needed(0.99 * N, N);
    EXPECT_TRUE(is_k_infinite(k_inf));
    EXPECT_EQ(binomial_tail_exact(1 << 20, k_inf, 0.999), 0.0);
    EXPECT_EQ(binomial_tail_normal(1 << 20, k_inf, 0.999), 0.0);
  }
  EXPECT_EQ(samples_needed(0.0, 1e9), 0.0);
  EXPECT_EQ(samples_needed(0.5, 0.0), 1.0);  // empty front (N_eff = 1): one sample
  EXPECT_EQ(samples_needed(0.5, 0.3), 1.0);
  EXPECT_TRUE(is_k_infinite(samples_needed(0.99, 0.3)));
  EXPECT_TRUE(is_k_infinite(samples_needed(kInf, 1e9)));
  // Big but finite: k ~ -ln(0.02) N for n = 0.98 N.
  EXPECT_NEAR(samples_needed(0.98e9, 1e9) / 1e9, -std::log(0.02), 1e-6);
  EXPECT_EQ(front_probability(5, 0), 0.0);
  EXPECT_EQ(front_probability(5, 10), 0.5);
  EXPECT_EQ(front_probability(12, 10), 1.0);
}

// ---- Eq. 21 and supplement A --------------------------------------------------------------------

TEST(BinomialTail, ExactMatchesScipyAtTestTime) {
  nlohmann::json q = nlohmann::json::array();
  std::vector<std::array<double, 3>> cases;
  for (int N : {1, 2, 5, 16, 32, 64, 100, 1000, 100000})
    for (double p : {0.0, 1e-6, 0.01, 0.1, 0.37, 0.5, 0.9, 0.999, 1.0})
      for (int k : {-1, 0, 1, 2, N / 3, N / 2, N - 1, N, N + 1}) {
        cases.push_back({double(N), double(k), p});
        q.push_back({N, k, p});
      }
  const auto in = temp_file("binom_in.json");
  std::ofstream(in) << q.dump();
  int rc = 0;
  const std::string out = run_capture(std::string(MDSTREAM_PYTHON) + " " + MDSTREAM_SOURCE_DIR +
                                          "/tests/tools/binom_reference.py < " + in.string(),
                                      &rc);
  std::filesystem::remove(in);
  ASSERT_EQ(rc, 0) << out;
  const auto ref = nlohmann::json::parse(out);
  ASSERT_EQ(ref.size(), cases.size());
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto& c = cases[i];
    const double mine = binomial_tail_exact(int(c[0]), c[1], c[2]);
    const double want = ref[i].get<double>();
    ASSERT_NEAR(mine, want, 1e-13 + 1e-10 * want) << "N=" << c[0] << " k=" << c[1] << " p=" << c[2];
  }
}

TEST(BinomialTail, NormalTableMatchesErfc) {
  for (int i = 0; i < MDS_CULL_NORMAL_TABLE_SIZE; ++i) {
    const double z = -MDS_CULL_NORMAL_TABLE_ZMAX +
                     2.0 * MDS_CULL_NORMAL_TABLE_ZMAX * i / (MDS_CULL_NORMAL_TABLE_SIZE - 1);
    ASSERT_NEAR(normal_cdf_table_entry(i), 0.5 * std::erfc(-z / std::sqrt(2.0)), 1e-16);
  }
  EXPECT_NEAR(normal_cdf_table_entry(MDS_CULL_NORMAL_TABLE_SIZE - 1),
              1.0 - MDS_CULL_NORMAL_TABLE_ALPHA, 1e-15);
  double max_err = 0.0;
  for (int i = 0; i <= 100000; ++i) {
    const double z = -5.0 + 10.0 * i / 100000;
    max_err = std::max(max_err, std::abs(normal_cdf_lookup(z) - 0.5 * std::erfc(-z / std::sqrt(2.0))));
  }
  // Interpolation error 1.8e-5 inside, truncation to 0/1 outside [-z_a, z_a]: alpha = 0.001.
  EXPECT_LE(max_err, MDS_CULL_NORMAL_TABLE_ALPHA + 1e-9);
  EXPECT_GT(max_err, 0.99 * MDS_CULL_NORMAL_TABLE_ALPHA);  // the truncation is really there
}

TEST(BinomialTail, NormalApproximationErrorBound) {
  // Grid: N_budget in {32..1024}, p in 999 steps over (0, 1), every k in [0, N+1].
  // Measured max |normal - exact|: 0.0204 where N p q >= 10 (the supplement's validity range),
  // 0.107 over all p (skewed tails: k = 1, N p < 1). Asserted bounds 0.025 / 0.11.
  // The supplement's literal lower limit k + c is measured alongside: 0.145 in the valid range
  // (it approximates P(X >= k + 1)), which is why we use k - c (see culling_math.h).
  double err_valid = 0, err_all = 0, err_literal = 0;
  for (int N : {32, 48, 64, 100, 128, 256, 512, 1024}) {
    for (int ip = 1; ip < 1000; ++ip) {
      const double p = ip / 1000.0;
      const double npq = N * p * (1 - p);
      for (int k = 0; k <= N + 1; ++k) {
        const double exact = binomial_tail_exact(N, k, p);
        const double e = std::abs(binomial_tail_normal(N, k, p) - exact);
        err_all = std::max(err_all, e);
        if (npq >= 10) {
          err_valid = std::max(err_valid, e);
          if (k >= 1 && k <= N) {
            const double lit = 1.0 - normal_cdf_lookup((k + 0.5 - N * p) / std::sqrt(npq));
            err_literal = std::max(err_literal, std::abs(lit - exact));
          }
        }
      }
    }
  }
  std::printf("normal approximation max abs error: N p q >= 10: %.4f, all p: %.4f, "
              "literal k + c: %.4f\n", err_valid, err_all, err_literal);
  EXPECT_LT(err_valid, 0.025);
  EXPECT_LT(err_all, 0.11);
  EXPECT_GT(err_literal, 0.1);
}

TEST(BinomialTail, EdgeCases) {
  for (auto tail : {&binomial_tail_exact, &binomial_tail_normal}) {
    EXPECT_EQ(tail(64, 0, 0.3), 1.0);      // k <= 0
    EXPECT_EQ(tail(64, -5, 0.0), 1.0);
    EXPECT_EQ(tail(64, 65, 0.999), 0.0);   // k > N_budget
    EXPECT_EQ(tail(64, kInf, 1.0), 0.0);   // symbolic infinity
    EXPECT_EQ(tail(64, MDS_CULL_K_INFINITE, 0.5), 0.0);
    EXPECT_EQ(tail(64, 3, 0.0), 0.0);      // p = 0: sigma = 0
    EXPECT_EQ(tail(64, 64, 1.0), 1.0);     // p = 1: sigma = 0
    EXPECT_EQ(tail(0, 1, 0.5), 0.0);       // N_budget = 0
    EXPECT_EQ(tail(0, 0, 0.5), 1.0);
    EXPECT_NEAR(tail(1, 1, 0.3), 0.3, 0.25);  // tiny N_budget stays in [0, 1]
    for (int N = 1; N <= 4; ++N)
      for (int k = 0; k <= N + 1; ++k)
        for (double p : {0.01, 0.5, 0.99}) {
          const double v = tail(N, k, p);
          ASSERT_TRUE(v >= 0.0 && v <= 1.0);
        }
  }
  EXPECT_NEAR(binomial_tail_exact(1, 1, 0.3), 0.3, 1e-15);
  EXPECT_NEAR(binomial_tail_exact(3, 3, 0.5), 0.125, 1e-15);
}

TEST(Acceptance, ProbabilityChainsEq15To22) {
  for (int mode : {MDS_CULL_ACCEPT_NORMAL, MDS_CULL_ACCEPT_EXACT}) {
    // Empty accumulation buffer (C = 0): always accept, also for an empty pixel.
    EXPECT_EQ(acceptance_probability(mode, 64, 0, 500, 0.0, 0.1, 3, 1000), 1.0);
    EXPECT_EQ(acceptance_probability(mode, 64, 0, 0, 0.0, 0.1, 0, 0), 1.0);
    // Current (d, C) unbeatable: C = 1 and nothing between d_s and d.
    EXPECT_EQ(acceptance_probability(mode, 64, 500, 500, 1.0, 0.1, 3, 1000), 0.0);
    // Would need more than eta of the front particles: clamped -> 0.
    EXPECT_EQ(acceptance_probability(mode, 64, 900, 1000, 0.95, 0.001, 10, 1000), 0.0);
    // k(d_s) > N_budget -> 0.
    const double n = unique_particles_needed(400, 600, 0.9, 0.01);
    const double k = samples_needed(n, 400);
    ASSERT_GT(k, 64);
    EXPECT_EQ(acceptance_probability(mode, 64, 400, 600, 0.9, 0.01, 400, 1000), 0.0);
    // An ordinary case equals the hand-chained formula.
    const double n2 = unique_particles_needed(400, 800, 0.9, 0.05);  // 11.65
    const double k2 = samples_needed(n2, 200);                        // 12
    EXPECT_EQ(k2, 12.0);
    const double P2 = binomial_tail(mode, 64, k2, front_probability(200, 1000));
    EXPECT_GT(P2, 0.3);
    EXPECT_LT(P2, 0.9);
    EXPECT_EQ(acceptance_probability(mode, 64, 400, 800, 0.9, 0.05, 200, 1000), P2);
  }
  EXPECT_EQ(acceptance_probability(MDS_CULL_ACCEPT_RANDOM, 64, 500, 500, 1.0, 0.1, 3, 1000), 0.5);
  EXPECT_FALSE(accept_sample(1e-300, 0.0));  // u in (0, 1]: P = 0 never accepts
  EXPECT_TRUE(accept_sample(1.0, 1.0));      // P = 1 always accepts
}

TEST(HardCases, EverythingStaysFinite) {
  const std::vector<double> Ns{0.0, 1e-300, 0.3, 1.0, 1.0 + 1e-12, 2.0, 1e9, 1e12, 1e300, kInf};
  const std::vector<double> as{0.0, 1e-300, 1e-9, 0.5, 1.0 - 1e-16, 1.0};
  const std::vector<double> ks{0.0, 1.0, 2.0, 64.0, 1e6, 1e12};
  const std::vector<double> Cs{0.0, 0.5, 1.0 - 1e-16, 1.0};
  for (double N : Ns) {
    ASSERT_FALSE(std::isnan(log_m(N)));
    for (double k : ks) {
      ASSERT_TRUE(std::isfinite(expected_unique(k, N))) << N << " " << k;
      ASSERT_TRUE(std::isfinite(expected_unique_increment(k, N))) << N << " " << k;
      for (double a : as) {
        const double c7 = confidence_constant_size(a, k, N);
        ASSERT_TRUE(c7 >= 0 && c7 <= 1) << a << " " << k << " " << N;
        for (double C : Cs) {
          const double c8 = accumulate_confidence(C, a, k, N);
          ASSERT_TRUE(c8 >= C && c8 <= 1) << C << " " << a << " " << k << " " << N;
          const double n = unique_particles_needed(N, 2 * N + 1, C, a);
          ASSERT_FALSE(std::isnan(n));
          ASSERT_GE(n, 0.0);
          const double kk = samples_needed(n, N);
          ASSERT_FALSE(std::isnan(kk));
          for (int mode : {MDS_CULL_ACCEPT_NORMAL, MDS_CULL_ACCEPT_EXACT}) {
            const double P = acceptance_probability(mode, 64, N, 2 * N + 1, C, a, N, 3 * N + 1);
            ASSERT_TRUE(P >= 0 && P <= 1) << P;
          }
        }
      }
    }
  }
}

// ---- Histograms (Eq. 9-12) ----------------------------------------------------------------------

DensityHistogram random_histogram(std::mt19937_64& rng, double total) {
  std::uniform_real_distribution<double> U(0.0, 1.0);
  DensityHistogram h;
  h.bins = 1 + static_cast<int>(U(rng) * MDS_CULL_HISTOGRAM_BINS) % MDS_CULL_HISTOGRAM_BINS;
  h.d_min = 1.0 + 10 * U(rng);
  h.d_max = h.d_min + 0.1 + 50 * U(rng);
  double s = 0;
  for (int i = 0; i < h.bins; ++i) s += (h.counts[i] = U(rng) < 0.2 ? 0.0 : std::exp(3 * U(rng)));
  if (s == 0.0) s = h.counts[0] = 1.0;  // keep at least one particle
  for (int i = 0; i < h.bins; ++i) h.counts[i] *= total / s;
  return h;
}

// Depth whose front count is q * total (inverse CDF): samples particles uniformly.
double sample_depth(const DensityHistogram& h, double q) {
  double lo = h.d_min, hi = h.d_max;
  for (int it = 0; it < 80; ++it) {
    const double mid = 0.5 * (lo + hi);
    (h.front(mid) < q * h.total() ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

TEST(Histogram, PiecewiseLinearCountsEq10Eq11) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (int t = 0; t < 200; ++t) {
    const auto h = random_histogram(rng, 1e3);
    const double total = h.total();
    EXPECT_EQ(h.front(h.d_min - 1), 0.0);
    EXPECT_NEAR(h.front(h.d_max), total, 1e-9 * total);
    EXPECT_EQ(h.behind(MDS_CULL_DEPTH_EMPTY), 0.0);
    EXPECT_NEAR(h.behind(h.d_min), total, 1e-9 * total);
    for (int i = 0; i < 50; ++i) {
      const double a = h.d_min + (h.d_max - h.d_min) * (1.2 * U(rng) - 0.1);
      const double b = h.d_min + (h.d_max - h.d_min) * (1.2 * U(rng) - 0.1);
      ASSERT_NEAR(h.front(a) + h.behind(a), total, 1e-9 * total);
      if (a < b) {
        ASSERT_NEAR(h.between(h.d_min, a) + h.between(a, b) + h.between(b, h.d_max), total,
                    1e-9 * total);
      }
    }
    // Linear within a bin: the midpoint of a bin holds half its count.
    const double w = (h.d_max - h.d_min) / h.bins;
    for (int i = 0; i < h.bins; ++i)
      ASSERT_NEAR(h.between(h.d_min + i * w, h.d_min + (i + 0.5) * w), 0.5 * h.counts[i], 1e-9 * total);
  }
  DensityHistogram empty;
  EXPECT_EQ(empty.total(), 0.0);
  EXPECT_EQ(empty.front(3.0), 0.0);
  EXPECT_EQ(empty.behind(3.0), 0.0);
}

TEST(RayCast, OrthographicAndPerspectiveMatchClosedForms) {
  DensityGrid g;
  g.dims = {5, 4, 6};
  g.origin = {-1.0, -2.0, 3.0};
  g.cell = {0.5, 1.0, 0.75};
  const double rho = 7.0;
  g.counts.assign(5 * 4 * 6, rho * 0.5 * 1.0 * 0.75);
  // Orthographic along +z through the box: D = rho A L, all bins equal.
  PixelRay o;
  o.perspective = false;
  o.ortho_pixel_area = 0.01;
  o.origin = {0.1, -0.3, 0.0};
  o.step = {0.0, 0.0, 1.0};
  auto h = cast_density_histogram(g, o, 64);
  ASSERT_EQ(h.bins, 64);
  EXPECT_NEAR(h.d_min, 3.0, 1e-12);
  EXPECT_NEAR(h.d_max, 7.5, 1e-12);
  EXPECT_NEAR(h.total(), rho * 0.01 * 4.5, 1e-12);
  for (int i = 0; i < 64; ++i) EXPECT_NEAR(h.counts[i], rho * 0.01 * 4.5 / 64, 1e-12);
  // Perspective from the origin: slab [z0, z1] of the frustum holds rho (z1^3 - z0^3) / (3 f^2).
  const auto pr = perspective_pixel_ray({0.0, -0.5, 0.0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, 0.6,
                                        64, 48, 40, 20);
  h = cast_density_histogram(g, pr, 17);
  ASSERT_EQ(h.bins, 17);
  const double f = pr.focal_px;
  EXPECT_NEAR(h.total(), rho * (std::pow(h.d_max, 3) - std::pow(h.d_min, 3)) / (3 * f * f), 1e-12);
  const double w = (h.d_max - h.d_min) / 17;
  for (int i = 0; i < 17; ++i) {
    const double z0 = h.d_min + i * w, z1 = z0 + w;
    EXPECT_NEAR(h.counts[i], rho * (z1 * z1 * z1 - z0 * z0 * z0) / (3 * f * f), 1e-12);
  }
  EXPECT_NEAR(footprint_area(2.0, true, f, 0, 0.0), 4.0 / (f * f), 1e-18);
  // The footprint grown by a particle radius R (Minkowski sum with the disk): footprint_count
  // integrates footprint_area exactly (Simpson is exact for the quadratic in z).
  for (bool persp : {true, false}) {
    const double R = 0.03, za = 2.5, zb = 4.0, A = 0.0004;
    const double simpson = (zb - za) / 6.0 *
                           (footprint_area(za, persp, f, A, R) + 4.0 * footprint_area(0.5 * (za + zb), persp, f, A, R) +
                            footprint_area(zb, persp, f, A, R));
    EXPECT_NEAR(footprint_count(rho, za, zb, persp, f, A, R), rho * simpson, 1e-12 * rho * simpson);
    const double width = persp ? 3.0 / f : 0.02;
    EXPECT_NEAR(footprint_area(3.0, persp, f, A, R), width * width + 4 * width * R + std::numbers::pi * R * R, 1e-15);
    EXPECT_NEAR(footprint_count(rho, za, zb, persp, f, A, 0.0),
                rho * (persp ? (zb * zb * zb - za * za * za) / (3 * f * f) : A * (zb - za)), 1e-12);
  }
  // A ray that misses: empty pixel.
  o.origin = {10.0, 0.0, 0.0};
  EXPECT_EQ(cast_density_histogram(g, o, 8).bins, 0);
}

TEST(RayCast, OrthographicImageConservesParticleCount) {
  // Pixels tile the grid's front face (4 x 4 pixels per cell): summing every pixel's histogram
  // recovers the grid's total count exactly (nearest-cell density integrates exactly).
  DensityGrid g;
  g.dims = {3, 4, 5};
  g.cell = {1.0, 1.0, 1.0};
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(0.0, 1000.0);
  double total = 0;
  for (int i = 0; i < 60; ++i) total += g.counts.emplace_back(U(rng));
  double sum = 0;
  for (int py = 0; py < 16; ++py)
    for (int px = 0; px < 12; ++px) {
      PixelRay r;
      r.perspective = false;
      r.ortho_pixel_area = 1.0 / 16;
      r.origin = {(px + 0.5) / 4, (py + 0.5) / 4, -2.0};
      r.step = {0, 0, 1};
      sum += cast_density_histogram(g, r, 1 + (px + py) % 64).total();
    }
  EXPECT_NEAR(sum, total, 1e-9 * total);
}

// ---- Algorithm 1 --------------------------------------------------------------------------------

TEST(Algorithm1, InvariantsOnRandomSampleStreams) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  int accepted_total = 0, copies = 0, extensions = 0;
  for (bool extend : {false, true})
  for (int mode : {MDS_CULL_ACCEPT_NORMAL, MDS_CULL_ACCEPT_EXACT, MDS_CULL_ACCEPT_RANDOM}) {
    for (double total : {0.0, 0.4, 10.0, 1e3, 1e6, 1e9}) {
      for (int pixel = 0; pixel < 30; ++pixel) {
        const auto h = random_histogram(rng, total == 0.0 ? 1.0 : total);
        DensityHistogram hist = h;
        if (total == 0.0) hist.counts.fill(0.0);  // empty histogram, samples still arrive
        PixelState px;
        const double r_px = std::exp(-4 + 5 * U(rng));  // projected radius, 0.02 .. 2.7 px
        double op_cull = 0.0, d_prev = px.d;
        for (int s = 0; s < 600; ++s) {
          const double d_s = sample_depth(h, U(rng));
          const double alpha = disk_pixel_coverage(U(rng), U(rng), r_px * (0.5 + U(rng)));
          const double u = 1.0 - U(rng);  // (0, 1]
          const auto before = px;
          update_depth_and_confidence(px, hist, d_s, alpha, u, {mode, 64, extend});
          ASSERT_TRUE(px.C >= 0 && px.C <= 1);
          ASSERT_TRUE(px.C_cull >= 0 && px.C_cull <= 1);
          if (!extend) {
            ASSERT_LE(px.d, d_prev);        // the accumulation depth only moves closer
            ASSERT_LE(px.d, px.d_cull);     // accumulation is never behind the cull buffer
          } else if (px.d > d_prev) {       // an extension: only where it occludes more
            ++extensions;
            ASSERT_GT(hist.occluded(px.d, px.C), hist.occluded(before.d, before.C));
          }
          ASSERT_GE(px.k, 1.0);
          const double op = hist.occluded(px.d_cull, px.C_cull);
          ASSERT_GE(op, op_cull);         // OP(d_cull, C_cull) never decreases
          if (px.d != before.d) ++accepted_total;
          if (px.d_cull != before.d_cull) ++copies;
          op_cull = op;
          d_prev = px.d;
        }
      }
    }
  }
  EXPECT_GT(accepted_total, 1000);  // the streams did exercise restarts, copies and extensions
  EXPECT_GT(copies, 1000);
  EXPECT_GT(extensions, 100);
}

TEST(Algorithm1, DepthExtensionJoinsTwoParticlesOfAPixel) {
  // A pixel on the boundary of two large particles in front of a thick block: the nearer one
  // covers 0.6 of it at depth 5.0, the farther one 0.4 at 5.1 (exact coverage). Nothing lies in
  // front of 5.0; the block behind holds 1e4 particles. Samples alternate, nearer one first.
  // Algorithm 1 keeps d = 5.0 and ignores the farther one's samples, so C stays at the nearer
  // one's share; with the extension the pixel's representative depth moves back to 5.1, where
  // both cover it, and C rises towards 1.
  DensityHistogram h;
  h.bins = 64;
  h.d_min = 4.92;
  h.d_max = 20.92;  // bins of 0.25: [4.92, 5.17) holds the two particles' neighbourhood
  h.counts[0] = 4.0;
  for (int i = 1; i < 64; ++i) h.counts[i] = 1e4 / 63;
  for (bool extend : {false, true}) {
    PixelState px;
    for (int s = 0; s < 64; ++s) {
      const bool nearer = s % 2 == 0;
      update_depth_and_confidence(px, h, nearer ? 5.0 : 5.1, nearer ? 0.6 : 0.4, 0.5, {MDS_CULL_ACCEPT_NORMAL, 64, extend});
    }
    if (extend) {
      EXPECT_EQ(px.d_cull, 5.1);
      EXPECT_GT(px.C_cull, 0.85);  // measured 0.887: N = D(d_min, 5.1) = 2.4 particles limits E(n)
    } else {
      EXPECT_EQ(px.d_cull, 5.0);
      EXPECT_LT(px.C_cull, 0.75);  // measured 0.69
    }
    std::printf("extension %d: d_cull %.2f, C_cull %.4f\n", int(extend), px.d_cull, px.C_cull);
  }
}

TEST(Algorithm1, ProbabilisticAcceptanceOccludesMoreThanRandom) {
  // Same histograms and sample streams; mean final OP(d_cull, C_cull) / total per pixel.
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  double op_prob = 0, op_rand = 0;
  for (int pixel = 0; pixel < 200; ++pixel) {
    const auto h = random_histogram(rng, 1e5);
    PixelState a, b;
    const double r_px = 0.3 + U(rng);
    for (int s = 0; s < 256; ++s) {
      const double d_s = sample_depth(h, U(rng));
      const double alpha = disk_pixel_coverage(U(rng), U(rng), r_px);
      const double u = 1.0 - U(rng);
      update_depth_and_confidence(a, h, d_s, alpha, u, {MDS_CULL_ACCEPT_NORMAL, 64});
      update_depth_and_confidence(b, h, d_s, alpha, u, {MDS_CULL_ACCEPT_RANDOM, 64});
    }
    op_prob += h.occluded(a.d_cull, a.C_cull) / h.total();
    op_rand += h.occluded(b.d_cull, b.C_cull) / h.total();
  }
  std::printf("mean occluded fraction: probabilistic %.3f, random %.3f\n", op_prob / 200,
              op_rand / 200);
  EXPECT_GT(op_prob, op_rand);
}

// ---- Eq. 23 pyramid -----------------------------------------------------------------------------

TEST(Pyramid, MaxDepthMeanConfidenceOddSizes) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (auto [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {2, 2}, {7, 5}, {1, 9}, {13, 1},
                                                      {16, 16}, {33, 17}}) {
    ConfidenceLevel base{w, h, {}, {}};
    for (int i = 0; i < w * h; ++i) {
      base.d.push_back(U(rng) < 0.1 ? MDS_CULL_DEPTH_EMPTY : 10 * U(rng));
      base.C.push_back(U(rng));
    }
    const auto levels = build_confidence_pyramid(base);
    const int expect_levels =
        1 + static_cast<int>(std::ceil(std::log2(static_cast<double>(std::max(w, h)))));
    ASSERT_EQ(static_cast<int>(levels.size()), expect_levels) << w << "x" << h;
    EXPECT_EQ(levels.back().width, 1);
    EXPECT_EQ(levels.back().height, 1);
    for (size_t l = 1; l < levels.size(); ++l) {
      const auto& c = levels[l];
      const int s = 1 << l;
      for (int y = 0; y < c.height; ++y)
        for (int x = 0; x < c.width; ++x) {
          // Depth: exactly the max over the covered base pixels (conservative).
          double dmax = -1;
          for (int by = y * s; by < std::min((y + 1) * s, h); ++by)
            for (int bx = x * s; bx < std::min((x + 1) * s, w); ++bx)
              dmax = std::max(dmax, base.d[by * w + bx]);
          ASSERT_EQ(c.d[y * c.width + x], dmax);
          // Confidence: mean of the existing 2x2 children.
          const auto& f = levels[l - 1];
          double sum = 0;
          int n = 0;
          for (int fy = 2 * y; fy < std::min(2 * y + 2, f.height); ++fy)
            for (int fx = 2 * x; fx < std::min(2 * x + 2, f.width); ++fx) sum += f.C[fy * f.width + fx], ++n;
          ASSERT_NEAR(c.C[y * c.width + x], sum / n, 1e-15);
          ASSERT_TRUE(c.C[y * c.width + x] >= 0 && c.C[y * c.width + x] <= 1);
        }
    }
    if (w == h && (w & (w - 1)) == 0) {  // power of two: the root is the global mean
      double mean = 0;
      for (double v : base.C) mean += v;
      EXPECT_NEAR(levels.back().C[0], mean / (w * h), 1e-12);
    }
  }
}

// ---- Sect. 5.1 classes --------------------------------------------------------------------------

TEST(Classes, RulesAndOnlyUpward) {
  const double co = MDS_CULL_C_OCC_DEFAULT, cm = MDS_CULL_C_MEDIUM_DEFAULT;
  EXPECT_EQ(classify_occlusion(MDS_CULL_CLASS_P, false, 1.0, co, cm), MDS_CULL_CLASS_P);
  EXPECT_EQ(classify_occlusion(MDS_CULL_CLASS_P, true, 0.96, co, cm), MDS_CULL_CLASS_O);
  EXPECT_EQ(classify_occlusion(MDS_CULL_CLASS_P, true, 0.95, co, cm), MDS_CULL_CLASS_M);
  EXPECT_EQ(classify_occlusion(MDS_CULL_CLASS_P, true, 0.51, co, cm), MDS_CULL_CLASS_M);
  EXPECT_EQ(classify_occlusion(MDS_CULL_CLASS_P, true, 0.5, co, cm), MDS_CULL_CLASS_L);
  EXPECT_EQ(classify_occlusion(MDS_CULL_CLASS_P, true, 0.0, co, cm), MDS_CULL_CLASS_L);
  EXPECT_EQ(classify_occlusion(MDS_CULL_CLASS_M, false, 0.0, co, cm), MDS_CULL_CLASS_M);
  EXPECT_EQ(classify_occlusion(MDS_CULL_CLASS_O, true, 0.0, co, cm), MDS_CULL_CLASS_O);
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (int m = 0; m < 1000; ++m) {
    int cls = MDS_CULL_CLASS_P;
    for (int it = 0; it < 30; ++it) {
      const bool failed = U(rng) < 0.7;
      const double C = U(rng);
      const int next = classify_occlusion(cls, failed, C, co, cm);
      ASSERT_GE(next, cls);
      ASSERT_TRUE(next >= MDS_CULL_CLASS_P && next <= MDS_CULL_CLASS_O);
      if (next == MDS_CULL_CLASS_O && cls != MDS_CULL_CLASS_O) {
        ASSERT_TRUE(failed && C > co);
      }
      cls = next;
    }
  }
}

// ---- Sect. 5: the box depth test per texel ---------------------------------------------------

// Random boxes in front of a camera at the origin looking down -z (world = view space), random
// texels of random pyramid levels: every box point whose projection falls into the texel is
// behind the entry depth of the texel's centre ray into the grown box, and such a texel is
// never reported as missed. Perspective and orthographic.
TEST(BoxTest, TexelEntryDepthIsConservative) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const double W = 320, H = 180, P11 = 1.0 / std::tan(0.5 * 40.0 * std::numbers::pi / 180.0), P00 = P11 * H / W;
  const double focal = 0.5 * H * P11;
  const double ortho_half_h = 20.0, ortho_P11 = 1.0 / ortho_half_h, ortho_P00 = ortho_P11 * H / W;
  const double ortho_pixel = (2.0 / (ortho_P00 * W)) * (2.0 / (ortho_P11 * H));
  int covered_texels = 0, skipped_texels = 0, checked_points = 0;
  for (int t = 0; t < 4000; ++t) {
    const bool perspective = t % 2 == 0;
    const double p00 = perspective ? P00 : ortho_P00, p11 = perspective ? P11 : ortho_P11;
    double lo[3], hi[3];
    const double size = std::pow(10.0, -1.0 + 2.0 * U(rng));
    const double z = 5.0 + 100.0 * U(rng);
    for (int a = 0; a < 2; ++a) {
      lo[a] = (perspective ? z * 0.5 : 20.0) * (2.0 * U(rng) - 1.0);
      hi[a] = lo[a] + size * (0.2 + U(rng));
    }
    lo[2] = -z - size;
    hi[2] = -z;
    const int level = int(5 * U(rng));
    const double s = double(1 << level);
    double zfar = 0.0;
    for (int c = 0; c < 8; ++c) zfar = std::max(zfar, -((c & 4) ? hi[2] : lo[2]));
    const double grow = texel_half_diagonal(s, zfar, perspective, focal, ortho_pixel);
    // Project points of the box; each names the texel it falls into.
    auto texel_of = [&](const double q[3], int& tx, int& ty) {
      const double w = perspective ? -q[2] : 1.0;
      const double px = (q[0] * p00 / w * 0.5 + 0.5) * W, py = (q[1] * p11 / w * 0.5 + 0.5) * H;
      if (px < 0 || py < 0 || px >= W || py >= H) return false;
      tx = int(px / s);
      ty = int(py / s);
      return true;
    };
    auto entry_of = [&](int tx, int ty) {
      const double nx = (tx + 0.5) * s / W * 2.0 - 1.0, ny = (ty + 0.5) * s / H * 2.0 - 1.0;
      double o[3] = {0, 0, 0}, dir[3] = {nx / p00, ny / p11, -1.0};
      if (!perspective) {
        o[0] = nx / p00;
        o[1] = ny / p11;
        dir[0] = dir[1] = 0.0;
      }
      return ray_box_entry(o, dir, lo, hi, grow, 0.1);
    };
    for (int k = 0; k < 64; ++k) {
      const double q[3] = {lo[0] + (hi[0] - lo[0]) * U(rng), lo[1] + (hi[1] - lo[1]) * U(rng),
                           lo[2] + (hi[2] - lo[2]) * U(rng)};
      int tx, ty;
      if (!texel_of(q, tx, ty)) continue;
      const double e = entry_of(tx, ty);
      ASSERT_LT(e, MDS_CULL_DEPTH_EMPTY) << "texel " << tx << "," << ty << " level " << level << " missed";
      ASSERT_LE(e, -q[2] * (1.0 + 1e-12)) << "entry behind a box point of the texel";
      ++checked_points;
    }
    // Texels far from the box are skipped (the test is not "always covered").
    int tx, ty;
    const double c[3] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), hi[2]};
    if (texel_of(c, tx, ty)) {
      for (int dx : {-3, 3}) {
        const int x = tx + dx * (1 + int(size * focal / (perspective ? z : 1.0) / s));
        if (x < 0 || x * s >= W) continue;
        ++(entry_of(x, ty) < MDS_CULL_DEPTH_EMPTY ? covered_texels : skipped_texels);
      }
    }
  }
  EXPECT_GT(checked_points, 100000);
  EXPECT_GT(skipped_texels, 1000) << "covered " << covered_texels;
}

TEST(BoxTest, FloatMirrorMatchesDouble) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  int hits = 0, disagree = 0;
  for (int t = 0; t < 20000; ++t) {
    double o[3], dir[3], lo[3], hi[3];
    double target[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = 20.0 * U(rng);
      hi[a] = lo[a] + 5.0 * (1.0 + U(rng));
      target[a] = 0.5 * (lo[a] + hi[a]) + 8.0 * U(rng);  // near the box: hits and misses
    }
    const double dist = 30.0 + 20.0 * U(rng);
    o[2] = target[2] + dist;
    dir[2] = -1.0;
    for (int a = 0; a < 2; ++a) {
      o[a] = target[a] + 20.0 * U(rng);
      dir[a] = (target[a] - o[a]) / dist;
    }
    if (t % 10 == 0) {  // parallel to a slab
      dir[0] = 0.0;
      o[0] = target[0];
    }
    const double grow = 0.5 * (1.0 + U(rng));
    const double e = ray_box_entry(o, dir, lo, hi, grow, 0.1);
    const float f = glslf::mds_ray_box_entry(float(o[0]), float(o[1]), float(o[2]), float(dir[0]), float(dir[1]),
                                             float(dir[2]), float(lo[0]), float(lo[1]), float(lo[2]), float(hi[0]),
                                             float(hi[1]), float(hi[2]), float(grow), 0.1f);
    const bool hd = e < MDS_CULL_DEPTH_EMPTY, hf = f < float(MDS_CULL_DEPTH_EMPTY);
    if (hd != hf) { ++disagree; continue; }  // grazing rays: float rounding at a slab edge
    if (hd) {
      ++hits;
      ASSERT_NEAR(f, e, 1e-4 * std::max(1.0, std::abs(e)));
    }
  }
  EXPECT_GT(hits, 1000);
  EXPECT_LT(disagree, 20);
  for (double z : {0.5, 10.0, 1e4})
    EXPECT_NEAR(glslf::mds_texel_half_diagonal(4.0f, float(z), true, 500.0f, 0.0f),
                texel_half_diagonal(4.0, z, true, 500.0, 0.0), 1e-6 * z);
  EXPECT_NEAR(glslf::mds_texel_half_diagonal(2.0f, 1.0f, false, 0.0f, 0.04f), texel_half_diagonal(2.0, 1.0, false, 0.0, 0.04),
              1e-7);
}

// ---- GLSL mirror -------------------------------------------------------------------------------

TEST(Glsl, CheckShaderCompilesToSpirv) {
  int rc = 0;
  const auto spv = temp_file("check.spv");
  const std::string out = run_capture(
      std::string("glslangValidator -V --target-env vulkan1.3 ") + MDSTREAM_SOURCE_DIR +
          "/shaders/tests/culling_math_check.comp -o " + spv.string() + " 2>&1",
      &rc);
  std::filesystem::remove(spv);
  if (WEXITSTATUS(rc) == 127) GTEST_SKIP() << "glslangValidator not installed";
  EXPECT_EQ(rc, 0) << out;
}

double rel_err(double got, double want) {
  return std::abs(got - want) / std::max(std::abs(want), 1e-30);
}

TEST(Glsl, FloatMirrorMatchesDoubleReference) {
  // The float algorithms of culling_math.glsl (compiled here as C++) against the double CPU
  // reference. C++ float log/exp are more accurate than GLSL's guarantees, so these bounds
  // check the algorithms (cancellation, N up to 1e9); the GPU parity test checks the hardware.
  double e_log1p = 0, e_expm1 = 0, e_E = 0, e_C = 0, e_alpha = 0, e_cdf = 0, e_P = 0;
  for (double x : {-0.999, -0.6, -0.5, -0.3, -1e-3, -1e-6, -1e-9, -1e-12, 0.0, 1e-7, 0.2, 0.49, 0.5, 3.0}) {
    e_log1p = std::max(e_log1p, x == 0 ? std::abs(glslf::mds_log1p(0.0f)) : rel_err(glslf::mds_log1p(float(x)), std::log1p(float(x))));
    e_expm1 = std::max(e_expm1, x == 0 ? std::abs(glslf::mds_expm1(0.0f)) : rel_err(glslf::mds_expm1(float(x)), std::expm1(float(x))));
  }
  EXPECT_LT(e_log1p, 1e-6);
  EXPECT_LT(e_expm1, 1e-6);
  for (double N : {0.0, 0.5, 1.0, 2.0, 10.0, 1e3, 1e6, 1e9}) {
    for (double k : {0.0, 1.0, 2.0, 7.0, 64.0, 1000.0}) {
      e_E = std::max(e_E, rel_err(glslf::mds_expected_unique(float(k), float(N)),
                                  expected_unique(float(k), float(N))));
      for (double a : {0.0, 1e-7, 1e-3, 0.1, 0.5, 1.0}) {
        for (double C : {0.0, 0.3, 0.99}) {
          // M^k below float's range (k |log M| > 87) flushes to 0 in float. That only matters
          // for a = 1 exactly, where 1 - 0^(M^k) jumps from 1 (double) to 0 (float).
          if (a == 1.0 && expected_unique_increment(k + 1, N) < 1e-30) continue;
          e_C = std::max(e_C, std::abs(glslf::mds_accumulate_confidence(float(C), float(a), float(k), float(N)) -
                                       accumulate_confidence(float(C), float(a), float(k), float(N))));
        }
        e_C = std::max(e_C, std::abs(glslf::mds_confidence_constant_size(float(a), float(k), float(N)) -
                                     confidence_constant_size(float(a), float(k), float(N))));
      }
    }
  }
  EXPECT_LT(e_E, 2e-6);
  EXPECT_LT(e_C, 2e-6);
  std::mt19937_64 rng_alpha(3);
  std::uniform_real_distribution<double> U_alpha(-1.5, 2.5);
  for (int i = 0; i <= 1000; ++i) {
    const double r = 2.0 * i / 1000;
    for (int j = 0; j < 8; ++j) {
      const float cx = float(U_alpha(rng_alpha)), cy = float(U_alpha(rng_alpha));
      e_alpha = std::max(e_alpha, std::abs(glslf::mds_disk_pixel_coverage(cx, cy, float(r)) -
                                           disk_pixel_coverage(cx, cy, float(r))));
    }
  }
  // Large disks, near their rim (close-ups): float loses ~6e-7 r^2 in the exact strips (r <= 32
  // px), and above them only the rounding of its inputs (~1.6e-7 r).
  for (double r : {8.0, 31.0, 33.0, 100.0, 1024.0}) {
    for (int j = 0; j < 2000; ++j) {
      const double ang = 2 * std::numbers::pi * U_alpha(rng_alpha), d = r + U_alpha(rng_alpha);
      const float cx = float(0.5 + d * std::cos(ang)), cy = float(0.5 + d * std::sin(ang));
      e_alpha = std::max(e_alpha, std::abs(glslf::mds_disk_pixel_coverage(cx, cy, float(r)) -
                                           disk_pixel_coverage(cx, cy, float(r))) /
                                       (r <= kCoverageLineRadius ? 1.0 + 2.0 * r * r : 1.0 + 2.0 * r));
    }
  }
  for (int i = 0; i <= 1000; ++i) {
    const double r = 2.0 * i / 1000;
    e_alpha = std::max(e_alpha, std::abs(glslf::mds_effective_particle_area(float(r)) - effective_particle_area(float(r))));
    const double z = -4.0 + 8.0 * i / 1000;
    e_cdf = std::max(e_cdf, std::abs(glslf::mds_normal_cdf_lookup(float(z)) - normal_cdf_lookup(float(z))));
  }
  EXPECT_LT(e_alpha, 2e-6);
  EXPECT_LT(e_cdf, 1e-6);
  // Acceptance chain: P within 1e-3 where k agrees; k within +-1 (ceil at near-integers).
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  int k_mismatch = 0, cases = 0;
  for (int t = 0; t < 20000; ++t) {
    const double total = std::pow(10.0, 9 * U(rng));
    const float D_front = float(total * U(rng)), B_ds = float(total) - D_front;
    const float B_d = float(B_ds * U(rng)), C = float(U(rng)), a = float(std::pow(U(rng), 2));
    const double n = unique_particles_needed(B_d, B_ds, C, a);
    const float nf = glslf::mds_unique_particles_needed(B_d, B_ds, C, a);
    if (std::isfinite(n) && n < 1e30) {
      ASSERT_LT(rel_err(nf, n), 1e-4) << B_d << " " << B_ds << " " << C << " " << a;
    }
    const double k = samples_needed(n, D_front);
    const float kf = glslf::mds_samples_needed(nf, D_front);
    ++cases;
    if (is_k_infinite(k) != glslf::mds_is_k_infinite(kf)) { ++k_mismatch; continue; }
    if (!is_k_infinite(k)) {
      ASSERT_LE(std::abs(kf - k), std::max(1.0, 1e-5 * k)) << n << " " << D_front;
      if (kf != k) ++k_mismatch;
    }
    const double P = acceptance_probability(MDS_CULL_ACCEPT_NORMAL, 64, B_d, B_ds, C, a, D_front, float(total));
    const float Pf = glslf::mds_acceptance_probability(MDS_CULL_ACCEPT_NORMAL, 64, B_d, B_ds, C, a, D_front, float(total));
    if (kf == k) e_P = std::max(e_P, std::abs(double(Pf) - P));
  }
  std::printf("float mirror: E rel %.2g, C abs %.2g, alpha abs %.2g, P abs %.2g, k differs in %d of %d\n",
              e_E, e_C, e_alpha, e_P, k_mismatch, cases);
  EXPECT_LT(e_P, 1e-3);
  EXPECT_LT(k_mismatch, cases / 100);
}

TEST(Glsl, FloatAlgorithm1MatchesDoubleStepByStep) {
  // One update from the same state and sample, float vs double, for random states.
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  int diverged = 0, n = 0;
  for (int t = 0; t < 3000; ++t) {
    const auto h = random_histogram(rng, std::pow(10.0, 1 + 8 * U(rng)));
    float counts[MDS_CULL_HISTOGRAM_BINS] = {};
    for (int i = 0; i < h.bins; ++i) counts[i] = float(h.counts[i]);
    DensityHistogram hf = h;  // the double reference sees the same float-rounded inputs
    for (int i = 0; i < h.bins; ++i) hf.counts[i] = counts[i];
    hf.d_min = float(h.d_min);
    hf.d_max = float(h.d_max);
    PixelState px;
    px.d_cull = float(sample_depth(h, U(rng)));
    px.d = float(std::min(px.d_cull, sample_depth(h, U(rng))));
    px.C = float(U(rng));
    px.C_cull = float(U(rng) * px.C);
    px.k = float(1 + int(50 * U(rng)));
    px.k_cull = float(1 + int(50 * U(rng)));
    float d = float(px.d), C = float(px.C), k = float(px.k), dc = float(px.d_cull),
          Cc = float(px.C_cull), kc = float(px.k_cull);
    const float d_s = float(sample_depth(h, U(rng))), alpha = float(U(rng)), u = float(1 - U(rng));
    const bool extend = t % 2 == 1;  // every other case with the depth extension
    update_depth_and_confidence(px, hf, d_s, alpha, u, {MDS_CULL_ACCEPT_NORMAL, 64, extend});
    glslf::mds_update_depth_and_confidence(d, C, k, dc, Cc, kc, counts, h.bins, float(h.d_min),
                                           float(h.d_max), d_s, alpha, u, MDS_CULL_ACCEPT_NORMAL, 64, extend);
    ++n;
    if (d != float(px.d) || dc != float(px.d_cull)) { ++diverged; continue; }  // u within eps of P
    ASSERT_NEAR(C, px.C, 1e-5);
    ASSERT_NEAR(Cc, px.C_cull, 1e-5);
    ASSERT_EQ(k, px.k);
    ASSERT_EQ(kc, px.k_cull);
  }
  EXPECT_LT(diverged, n / 200);
}

}  // namespace
