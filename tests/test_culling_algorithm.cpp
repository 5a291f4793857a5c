// Tests of the culling loop's parts (paper 000, Eq. 9-12 and 23, Algorithm 1, Sect. 5.1):
// per-pixel density histograms and ray casts (src/culling/density_histogram.*), Algorithm 1 and
// its depth extension (confidence_buffer.*), the pyramid, the classes and the box test, and the
// float algorithms of the GLSL mirror shaders/include/culling_math.glsl (compiled here as C++
// through glsl_float_shim.h, and as SPIR-V with glslangValidator) against the double reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <sys/wait.h>

#include "culling/confidence_buffer.h"
#include "culling/culling_constants.h"
#include "culling/culling_math.h"
#include "culling/density_histogram.h"
#include "culling_test_util.h"
#include "glsl_float_shim.h"

namespace {

using namespace mds::culling;
using mds::culling::test::run_capture;
using mds::culling::test::temp_file;
constexpr double kInf = std::numeric_limits<double>::infinity();

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
  // --coverage auto: the switch at kMixedExactBelowPx (the same side in float and double).
  for (int i = 0; i <= 4000; ++i) {
    const double r = kMixedExactBelowPx * (0.5 + 1.0 * i / 4000);
    const float cx = float(U_alpha(rng_alpha)), cy = float(U_alpha(rng_alpha));
    e_alpha = std::max(e_alpha, std::abs(glslf::mds_mixed_pixel_coverage(cx, cy, float(r)) -
                                         mixed_pixel_coverage(cx, cy, float(r))));
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
