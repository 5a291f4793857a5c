// The occlusion sampling pass's two routes (rasterized, compute) and the automatic choice between
// them by GPU timings (docs/rendering.md "Occlusion sampling pass"). No Vulkan: the culling loop
// (cull_sampling.cpp) records and times the passes, SampleRouteChooser decides.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace mds::render::culling {

enum class SampleRoute : uint8_t { automatic, compute, raster };
// Iterations from one route comparison to the next (automatic route choice). After a comparison
// that ended early (the clear-cut rule below) with the same winner as the one before, the next
// waits twice as long, up to kSampleRouteExploreMax; any other outcome, and every new view,
// return to kSampleRouteExplore.
inline constexpr uint32_t kSampleRouteExplore = 16;
inline constexpr uint32_t kSampleRouteExploreMax = 128;
// Timed sampling passes per route in one comparison (their median decides: robust against a
// pass that pays a one-time cost; with 4 passes per iteration, the first two iterations).
inline constexpr uint32_t kSampleRouteCompare = 4;
// A comparison ends early, once each route has kSampleRouteEarly timed passes, when every pass of
// one route took at least kSampleRouteClearCut times the slowest pass of the other: the other
// route wins, and the loser's remaining passes (up to ~200 ms each on a close-up at rest) are
// not paid. Two passes per route is one iteration of 4 passes.
inline constexpr uint32_t kSampleRouteEarly = 2;
inline constexpr double kSampleRouteClearCut = 2.0;
// The probe of a repeat comparison is an extra pass on the other route that only measures: it
// selects 1/kSampleRouteProbeShare of the occluder budget, samples them, and its samples are
// dropped (no update), while the iteration's passes all run on the winner; its time counts
// kSampleRouteProbeShare times (a pass's cost grows with its occluders: one glyph setup or
// invocation each, and their pixels). So the loop's state never depends on the timings (both
// routes give the same samples, and the probe gives none), and the probe costs a quarter of the
// slower route's pass instead of a whole one: on lavapipe up to 220 ms on the cache benchmark's
// views, where the running route's took 30-60, the frames that paid for it a path's p99.
// The probe decides at once when the clear-cut rule holds either way: the winner stays, or the
// probed route takes over (its estimate is high -- the pass's fixed cost counted share times --
// so a clear-cut win of the estimate is one of the route). Otherwise whole passes alternate.
// (Until 2026-11-28 a probe that found the other route clearly faster went on alternating: the
// H200's porous 1.5M jumps ran two more 4.3 ms compute passes beside 0.24 ms raster ones.)
inline constexpr uint32_t kSampleRouteProbeShare = 4;
// While the camera moves (set_moving) there are no whole passes of both routes: every view lasts
// one frame of one pass, and a comparison that alternated routes paid the slower one's pass in
// its frames. A moving comparison is one probe (above) next to the running route's pass, at the
// first moving iteration without a winner (compute running) and whenever a pass of the running
// route took more than kSampleRouteClearCut x its compared time and more than the other route's
// compared time (the view changed: a camera entering dense data makes the compute route's
// glyphs large; sample_route_run_slowed). The probed route takes over when
// kSampleRouteMovingHysteresis x its estimate is below the running route's pass. At rest the
// same slowed pass starts the next iteration's probe at once instead of kSampleRouteExplore
// iterations later (since 2026-11-28: on the H200 a jump to a close-up ran 3-4 compute passes
// of 3-4.5 ms before its probe, where the rasterized route took 0.24).
inline constexpr double kSampleRouteMovingHysteresis = 1.5;
// The probe of a moving comparison selects 1/kSampleRouteMovingProbeShare of the budget (its
// time counts as many times): its cost lands in a moving frame, which the frame pacer holds near
// its target, and a 1.5x gap needs no finer estimate. On lavapipe a quarter-budget raster probe
// took 28 ms next to a 20 ms compute pass (porous fly-through, 320x180 at scale 0.5); the
// slowest of frames 3-9 of the dynamic-resolution fly-throughs went 56-64 -> 45-48 ms (porous)
// and 50-62 -> 44-49 ms (ablation), medians of 8-10 runs (docs/rendering.md "Occlusion
// sampling pass").
inline constexpr uint32_t kSampleRouteMovingProbeShare = 16;
// A probe at rest (a repeat comparison) costs about kSampleRouteProbeCost x the running route's
// pass at most: when the last comparison found the other route r times slower, the probe
// selects 1/ceil(r / kSampleRouteProbeCost) of the budget, between kSampleRouteProbeShare and
// kSampleRouteMovingProbeShare. The probe only has to tell whether the other route came within
// kSampleRouteClearCut of the winner; with r = 9 (lavapipe's raster route on the cache
// benchmark's views) a quarter-budget probe took 2.2 passes of the running route, 45-50 ms in one
// frame, the ablation jumps' p99 (docs/rendering.md, "Occlusion sampling pass"). A smaller share
// counts the pass's fixed cost more times, which errs toward keeping the winner.
inline constexpr double kSampleRouteProbeCost = 0.5;
// The probe share above: moving, kSampleRouteMovingProbeShare; at rest from the last compared
// ms per pass of the winner and of the other route (kSampleRouteProbeShare when either is
// unknown, <= 0).
uint32_t sample_route_probe_share(double winner_ms, double other_ms, bool moving);
// The clear-cut rule: 0 (raster) or 1 (compute) when every timed pass of the other route took at
// least kSampleRouteClearCut times the winner's slowest pass; -1 otherwise (or when either
// route has no pass yet).
int sample_route_clear_winner(std::span<const double> raster_ms, std::span<const double> compute_ms);
// The slowed-pass rule above: a pass of the running route that took more than
// kSampleRouteClearCut x that route's compared ms and more than the other route's compared ms
// (a compared time <= 0, i.e. unknown, never holds it back).
bool sample_route_run_slowed(double pass_ms, double running_compared_ms, double other_compared_ms);

// The automatic route choice as a state machine over GPU timings, without Vulkan (the culling
// loop records and times the passes, cull_sampling.cpp; tests feed it timings). Per culling
// iteration: begin_iteration, then probing() / pass_route() for what to record and
// times_passes() / comparing() for how to label the timings; once the iteration completed on
// the GPU, collect() with its timings. Routes: kRaster = 0, kCompute = 1 (SampleRoute's
// indices in the stats).
class SampleRouteChooser {
 public:
  static constexpr int kRaster = 0, kCompute = 1;
  enum class Kind : uint8_t {
    compared,  // a pass of a comparison ("raster" / "compute")
    run,       // a pass of the running route outside a comparison ("run_raster" / "run_compute")
    probe,     // the probe: ms already multiplied by its share (its estimate of a whole pass)
  };
  struct Timing {
    int route = kCompute;
    Kind kind = Kind::compared;
    double ms = 0.0;
  };

  // Before an iteration's passes are recorded: a comparison or probe begins when none is under
  // way and (moving) no route has won or the last collect() saw a slowed pass, or (at rest) no
  // route has won, a slowed pass, or kSampleRouteExplore..Max iterations since the last one.
  void begin_iteration(bool moving);
  // The route is forced or the compute route missing: no comparison under way.
  void stop();
  // A new view: the next comparison at rest comes kSampleRouteExplore iterations after the last.
  void new_view() { explore_interval_ = kSampleRouteExplore; }
  // This iteration starts with a probe of probe_route() (an extra pass that only measures).
  bool probing() const { return probing_; }
  int probe_route() const { return 1 - best_; }
  // The probe's budget divisor (sample_route_probe_share): from the last comparison, or from
  // the slowed pass that started the probe (at rest) -- the last comparison's ratio is stale then.
  uint32_t probe_share() const;
  // The route of pass p of the iteration's pass_count passes.
  int pass_route(uint32_t p, uint32_t pass_count) const;
  // The iteration's passes are timed (a comparison, or a running route to watch) and, when not
  // comparing, labelled Kind::run.
  bool times_passes() const { return comparing_ || best_ >= 0; }
  bool comparing() const { return comparing_; }
  // The iteration's timings, after it completed: decides a comparison, or notes a slowed pass.
  void collect(std::span<const Timing> timings);
  // The winner (-1: none yet) and the last finished comparison's median ms per pass (-1: none).
  int best() const { return best_; }
  double compared_ms(int route) const { return compared_[route]; }

 private:
  int best_ = -1;
  bool comparing_ = false;
  bool probing_ = false;             // comparing, first iteration of a repeat: a probe
  bool moving_comparison_ = false;   // comparing: begun while moving (one probe decides)
  bool trigger_ = false;             // collect() saw a slowed pass of the running route
  double trigger_ms_ = -1.0;         // the slowest such pass
  double running_ms_ = -1.0;         // the running route's ms per pass the probe's share is sized by
  bool probe_estimate_ = false;      // compare_[probed route] starts with the probe's estimate
  uint32_t since_compare_ = 0;       // iterations since the last comparison started
  uint32_t explore_interval_ = kSampleRouteExplore;
  std::vector<double> compare_[2];   // ms per pass of the comparison so far
  double compared_[2] = {-1.0, -1.0};
};

}  // namespace mds::render::culling
