// Tests of the culling formulas of Ibrahim et al. 2021 (paper 000, Eq. 1-22 and supplement A):
// coverage, unique particles and confidence (Sect. 4.1), the particle-size areas, thresholds,
// binomial tails and acceptance (Sect. 4.5) of src/culling/culling_math.*, and their hard cases.
// Histograms, ray casts, Algorithm 1, the pyramid, classes and the GLSL mirror are in
// test_culling_algorithm.cpp.
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

#include <nlohmann/json.hpp>

#include "culling/culling_constants.h"
#include "culling/culling_math.h"
#include "culling_test_util.h"

namespace {

using namespace mds::culling;
using mds::culling::test::run_capture;
using mds::culling::test::temp_file;
constexpr double kInf = std::numeric_limits<double>::infinity();

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

// --coverage auto: exact clipping below kMixedExactBelowPx, the expected area (1 there) from it
// on; the switch is where a pixel at a disk's rim jumps to 1.
TEST(DiskPixelCoverage, MixedSwitchesToTheExpectedAreaAtTheSwitchRadius) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(-3.0, 4.0);
  for (int i = 0; i < 2000; ++i) {
    const double cx = U(rng), cy = U(rng), r = 0.01 + 2.0 * kMixedExactBelowPx * (i + 0.5) / 2000;
    const double want = r < kMixedExactBelowPx ? disk_pixel_coverage(cx, cy, r) : effective_particle_area(r);
    ASSERT_EQ(mixed_pixel_coverage(cx, cy, r), want) << cx << " " << cy << " " << r;
  }
  EXPECT_EQ(effective_particle_area(kMixedExactBelowPx), 1.0);
  const double T = kMixedExactBelowPx, below = std::nextafter(T, 0.0);
  EXPECT_NEAR(mixed_pixel_coverage(0.5 + T, 0.5, below), 0.5, 0.03);  // the rim through the pixel's middle
  EXPECT_EQ(mixed_pixel_coverage(0.5 + T, 0.5, T), 1.0);
  EXPECT_EQ(mixed_pixel_coverage(2.0 + 2.0 * T, 0.5, T), 1.0);  // the expected area: any pixel
  EXPECT_EQ(mixed_pixel_coverage(0.5, 0.5, 0.0), 0.0);
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

}  // namespace
