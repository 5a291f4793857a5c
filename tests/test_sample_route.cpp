// The automatic choice between the occlusion sampling pass's two routes (render/culling/
// sample_route.h), fed with timings: the clear-cut rule, the probe's share, and the chooser's
// decisions on timing traces such as the H200's (docs/results/gpu-h200.md, run 13). The routes'
// samples are compared on lavapipe in test_cull_render (CullRender.ComputeAndRasterizedSamplingAgree).
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "render/culling/sample_route.h"

using mds::render::culling::SampleRouteChooser;

namespace {

constexpr int R = SampleRouteChooser::kRaster, C = SampleRouteChooser::kCompute;
using Kind = SampleRouteChooser::Kind;

// One culling iteration of `passes` sampling passes with the given ms per pass of each route,
// timed as the culling loop times them (cull_loop.cpp record_iteration, cull_sampling.cpp
// collect_route_timings). Returns the routes of the passes whose samples count, and sets *probe
// to the probed route (-1: none) and *share to the probe's budget divisor. A pass of a route
// costs fixed_ms of its ms whatever its occluders (render pass, clears, barriers) and the rest
// in proportion: a probe over 1/share of the budget takes fixed + (ms - fixed) / share, counted
// share times.
std::vector<int> iterate(SampleRouteChooser& ch, bool moving, uint32_t passes, double raster_ms, double compute_ms,
                         int* probe = nullptr, uint32_t* share = nullptr, double fixed_ms = 0.0) {
  ch.begin_iteration(moving);
  const uint32_t s = ch.probing() ? ch.probe_share() : 0;
  if (share) *share = s;
  std::vector<SampleRouteChooser::Timing> t;
  const double ms[2] = {raster_ms, compute_ms};
  if (probe) *probe = ch.probing() ? ch.probe_route() : -1;
  if (ch.probing()) {
    const double m = ms[ch.probe_route()];
    t.push_back({ch.probe_route(), Kind::probe, s * (fixed_ms + (m - fixed_ms) / s)});
  }
  std::vector<int> routes;
  const bool timed = ch.times_passes();
  const Kind kind = ch.comparing() ? Kind::compared : Kind::run;
  for (uint32_t p = 0; p < passes; ++p) {
    const int r = ch.pass_route(p, passes);
    routes.push_back(r);
    if (timed) t.push_back({r, kind, ms[r]});
  }
  ch.collect(t);
  return routes;
}

int count(const std::vector<int>& v, int r) {
  int n = 0;
  for (int x : v) n += x == r;
  return n;
}

}  // namespace

// The comparison of the sampling routes ends early only when one route is clearly slower: every
// pass of it at least kSampleRouteClearCut times the other's slowest.
TEST(SampleRouteChoice, ClearCutRuleDecidesOnlyOnAClearGap) {
  using mds::render::culling::sample_route_clear_winner;
  const std::vector<double> none, fast{18.0, 19.5}, slow{140.0, 205.0}, close{25.0, 60.0};
  EXPECT_EQ(sample_route_clear_winner(fast, slow), 0);   // raster fast, compute slow
  EXPECT_EQ(sample_route_clear_winner(slow, fast), 1);   // compute fast
  EXPECT_EQ(sample_route_clear_winner(fast, close), -1);  // a compute pass within 2x of raster's slowest
  EXPECT_EQ(sample_route_clear_winner(close, fast), -1);
  EXPECT_EQ(sample_route_clear_winner(fast, fast), -1);
  EXPECT_EQ(sample_route_clear_winner(none, slow), -1);
  EXPECT_EQ(sample_route_clear_winner(std::vector<double>{10.0}, std::vector<double>{20.0}), 0);  // 2x exactly
  EXPECT_EQ(sample_route_clear_winner(std::vector<double>{10.0}, std::vector<double>{19.9}), -1);
}

// A probe at rest selects a smaller share of the budget the slower the other route was found:
// about kSampleRouteProbeCost of the winner's pass, within [kSampleRouteProbeShare,
// kSampleRouteMovingProbeShare]; a moving probe always the moving share.
TEST(SampleRouteChoice, ProbeShareFollowsTheLastComparedRatio) {
  using namespace mds::render::culling;
  EXPECT_EQ(sample_route_probe_share(-1.0, -1.0, false), kSampleRouteProbeShare);  // nothing compared yet
  EXPECT_EQ(sample_route_probe_share(10.0, -1.0, false), kSampleRouteProbeShare);
  EXPECT_EQ(sample_route_probe_share(0.0, 5.0, false), kSampleRouteProbeShare);
  EXPECT_EQ(sample_route_probe_share(10.0, 12.0, false), kSampleRouteProbeShare);  // routes close: a quarter
  EXPECT_EQ(sample_route_probe_share(10.0, 20.0, false), 4u);                      // 2x: 2 / 0.5
  EXPECT_EQ(sample_route_probe_share(10.0, 30.0, false), 6u);                      // 3x: a sixth costs half a pass
  EXPECT_EQ(sample_route_probe_share(10.0, 30.5, false), 7u);                      // rounded up
  EXPECT_EQ(sample_route_probe_share(1.1, 9.74, false), kSampleRouteMovingProbeShare);  // 8.9x: capped
  EXPECT_EQ(sample_route_probe_share(1.1, 9.74, true), kSampleRouteMovingProbeShare);
  EXPECT_EQ(sample_route_probe_share(10.0, 12.0, true), kSampleRouteMovingProbeShare);  // moving: always 1/16
  for (double r = 0.5; r < 40.0; r *= 1.3) {  // a probe at rest costs at most half a winner's pass, or 1/16
    const uint32_t s = sample_route_probe_share(10.0, 10.0 * r, false);
    EXPECT_TRUE(r / s <= kSampleRouteProbeCost + 1e-12 || s == kSampleRouteMovingProbeShare) << r;
  }
}


// The first comparison at rest alternates whole passes; a clear gap ends it after
// kSampleRouteEarly passes per route, and the faster route runs alone until the repeat, a probe
// kSampleRouteExplore iterations later. A probe that confirms the winner doubles the interval.
TEST(SampleRouteChooser, ComparesAtRestThenProbesAtGrowingIntervals) {
  using namespace mds::render::culling;
  SampleRouteChooser ch;
  const std::vector<int> first = iterate(ch, false, 4, 10.0, 3.0);
  EXPECT_EQ(count(first, C), 2);
  EXPECT_EQ(count(first, R), 2);
  ASSERT_EQ(ch.best(), C) << "compute 3 ms against raster 10 ms is a clear gap";
  EXPECT_DOUBLE_EQ(ch.compared_ms(C), 3.0);
  EXPECT_DOUBLE_EQ(ch.compared_ms(R), 10.0);
  std::vector<int> probes;
  for (int it = 1; it < 120; ++it) {
    int probe = -1;
    uint32_t share = 0;
    const std::vector<int> routes = iterate(ch, false, 4, 10.0, 3.0, &probe, &share);
    EXPECT_EQ(count(routes, C), 4) << "iteration " << it << ": a whole pass of the slower route";
    if (probe >= 0) {
      EXPECT_EQ(probe, R);
      EXPECT_EQ(share, 7u) << "10 / 3 slower: 1/ceil(3.33 / 0.5) of the budget";
      probes.push_back(it);
    }
  }
  EXPECT_EQ(probes, (std::vector<int>{int(kSampleRouteExplore), int(3 * kSampleRouteExplore),
                                      int(7 * kSampleRouteExplore)}));
  EXPECT_EQ(ch.best(), C);
}

// Routes within kSampleRouteClearCut of each other: the probe decides nothing, and the
// comparison goes on with whole passes of both routes (the probe's time counts); the faster by
// median wins.
TEST(SampleRouteChooser, AProbeWithoutAClearGapGoesOnComparing) {
  SampleRouteChooser ch;
  iterate(ch, false, 4, 4.0, 3.0);
  iterate(ch, false, 4, 4.0, 3.0);  // 4 passes each (kSampleRouteCompare): no clear gap, the median
  ASSERT_EQ(ch.best(), C);
  int probe_at = -1;
  for (int it = 2; it < 40 && probe_at < 0; ++it) {
    int probe = -1;
    iterate(ch, false, 4, 4.0, 3.0, &probe);
    if (probe >= 0) probe_at = it;
  }
  ASSERT_GT(probe_at, 0);
  EXPECT_TRUE(ch.comparing()) << "a probe within 2x ended the comparison";
  const std::vector<int> next = iterate(ch, false, 4, 4.0, 3.0);
  EXPECT_EQ(count(next, R), 2) << "the comparison's passes alternate";
  EXPECT_EQ(ch.best(), C);
}

// The H200's porous 1.5M jumps (docs/results/gpu-h200.md, run 13): a far view compared compute
// 0.066 ms against raster 1.83 ms per pass; the jump to a close-up at rest made compute 4.3 ms
// and raster 0.24 ms, most of it fixed (a 1/16 probe counted 16 times came to more than 2.15 ms).
// The first slowed compute pass starts a probe in the next iteration, sized by that pass (a
// quarter: the other route's 1.83 ms is under 2x of 4.3) rather than by the stale 28x ratio
// (1/16), and its clear-cut estimate hands over at once: two compute passes after the jump
// instead of the 3-4.5 ms passes until the interval and then whole passes of both routes.
// Fails with any of the three rules removed (checked by mutation).
TEST(SampleRouteChooser, ASlowedPassAtRestProbesAndAClearProbeHandsOver) {
  using namespace mds::render::culling;
  SampleRouteChooser ch;
  for (int it = 0; it < 4; ++it) iterate(ch, false, 1, 1.83, 0.066);  // one pass per iteration (paced)
  ASSERT_EQ(ch.best(), C);
  EXPECT_FALSE(ch.comparing());
  for (int it = 0; it < 3; ++it) iterate(ch, false, 1, 1.83, 0.066);  // held: nothing changes
  ch.new_view();
  int compute_passes = 0, probes = 0;
  uint32_t probe_share = 0;
  for (int it = 0; it < 12; ++it) {
    int probe = -1;
    uint32_t share = 0;
    const std::vector<int> routes = iterate(ch, false, 1, 0.24, 4.3, &probe, &share, 0.15);
    compute_passes += count(routes, C);
    if (probe >= 0) {
      ++probes;
      probe_share = share;
    }
  }
  EXPECT_EQ(probes, 1);
  EXPECT_EQ(probe_share, kSampleRouteProbeShare) << "sized by the slowed pass";
  EXPECT_EQ(compute_passes, 2) << "compute passes after the jump: the slowed one and the probe's iteration";
  EXPECT_EQ(ch.best(), R);
  EXPECT_DOUBLE_EQ(ch.compared_ms(C), 4.3);
}

// A probe that decides nothing (here: a scheduled one, whose share follows the last comparison,
// and a pass that is mostly fixed cost, so its estimate is high) is followed by a whole pass of
// the probed route, which replaces the estimate; the clear-cut rule then decides on whole passes.
TEST(SampleRouteChooser, AWholePassReplacesAnUndecidedProbesEstimate) {
  using namespace mds::render::culling;
  SampleRouteChooser ch;
  iterate(ch, false, 4, 7.0, 3.0);
  ASSERT_EQ(ch.best(), C);
  int it = 1;
  for (; it < int(kSampleRouteExplore); ++it) iterate(ch, false, 1, 7.0, 3.0);
  // The scene changed without slowing compute: raster now 1 ms a pass, 0.9 of it fixed. The
  // probe (1/ceil(2.33 / 0.5) = 1/5) estimates 5 x 0.92 = 4.6 ms: no clear gap.
  int probe = -1;
  uint32_t share = 0;
  std::vector<int> routes = iterate(ch, false, 1, 1.0, 3.0, &probe, &share, 0.9);
  ASSERT_EQ(probe, R);
  EXPECT_EQ(share, 5u);
  EXPECT_EQ(routes, std::vector<int>{C});
  ASSERT_TRUE(ch.comparing());
  std::vector<int> next;
  for (int k = 0; k < 3 && ch.comparing(); ++k) {
    const std::vector<int> r = iterate(ch, false, 1, 1.0, 3.0, nullptr, nullptr, 0.9);
    next.insert(next.end(), r.begin(), r.end());
  }
  EXPECT_EQ(next, (std::vector<int>{R, C, R})) << "the probed route's whole pass first, then alternating";
  EXPECT_FALSE(ch.comparing());
  EXPECT_EQ(ch.best(), R) << "raster 1.0 against compute 3.0 on whole passes is a clear gap";
  EXPECT_DOUBLE_EQ(ch.compared_ms(R), 1.0);
}

// A running route's passes that stay within kSampleRouteClearCut of its compared time, or below
// the other route's, start no probe before the interval.
TEST(SampleRouteChooser, SteadyPassesAtRestStartNoProbe) {
  using namespace mds::render::culling;
  EXPECT_TRUE(sample_route_run_slowed(7.0, 3.0, 6.0));
  EXPECT_FALSE(sample_route_run_slowed(5.9, 3.0, 4.0));   // within 2x of its own
  EXPECT_FALSE(sample_route_run_slowed(7.0, 3.0, 8.0));   // slower, but still faster than the other
  EXPECT_TRUE(sample_route_run_slowed(0.5, -1.0, -1.0));  // nothing compared: a probe tells
  SampleRouteChooser ch;
  iterate(ch, false, 4, 10.0, 3.0);
  ASSERT_EQ(ch.best(), C);
  for (int it = 1; it < int(kSampleRouteExplore); ++it) {
    int probe = -1;
    iterate(ch, false, 4, 10.0, it % 2 ? 5.5 : 2.0, &probe);  // jitter within 2x of 3 ms
    EXPECT_EQ(probe, -1) << "iteration " << it;
  }
}

// While the camera moves there are only probes: the running route (compute first) samples, the
// other is probed beside it, and takes over when kSampleRouteMovingHysteresis x its estimate is
// below the running route's pass.
TEST(SampleRouteChooser, AMovingCameraDecidesByOneProbeWithHysteresis) {
  using namespace mds::render::culling;
  for (const auto& [raster, switches] : {std::pair{1.0, true}, std::pair{1.5, false}}) {
    SampleRouteChooser ch;
    int probe = -1;
    uint32_t share = 0;
    const std::vector<int> routes = iterate(ch, true, 1, raster, 2.0, &probe, &share);
    EXPECT_EQ(routes, std::vector<int>{C});
    EXPECT_EQ(probe, R);
    EXPECT_EQ(share, kSampleRouteMovingProbeShare);
    EXPECT_FALSE(ch.comparing());
    EXPECT_EQ(ch.best(), switches ? R : C) << "raster " << raster << " ms against compute 2 ms";
    // No further probe while the passes hold steady.
    for (int it = 0; it < 8; ++it) {
      iterate(ch, true, 1, raster, 2.0, &probe);
      EXPECT_EQ(probe, -1);
    }
  }
}

// A forced route (or none to compare) ends a comparison under way.
TEST(SampleRouteChooser, StopEndsAComparison) {
  SampleRouteChooser ch;
  ch.begin_iteration(false);
  ASSERT_TRUE(ch.comparing());
  ch.stop();
  EXPECT_FALSE(ch.comparing());
  EXPECT_FALSE(ch.probing());
}
