// Paced occlusion sampling at rest: the sampling passes of a culling iteration (paper 000,
// Sect. 3.2: several passes per iteration, Algorithm 1 after each) follow the cost of a pass in
// the current view against the cost of a pass in the views held before it, so that one
// expensive view (a close-up whose glyphs cover the image: 2-3x the pass time of the views
// around it on lavapipe) spreads its refinement over more frames instead of taking frames of
// 2-3x the usual length (docs/rendering.md, "Paced sampling at rest").
//   passes = clamp(floor(full * kSlack * reference / view_pass_ms), 1, full)
// reference = the median over the last kHistory views held at rest of each view's median
// per-pass GPU time; view_pass_ms = the per-pass time of this view's last iteration. Only other
// views set the pace: a single held view whose passes grow as its data streams in keeps every
// pass. The iteration's classification and convergence test stay per iteration; the renderer
// counts quiet *passes* so that a paced view still needs converge_iterations x full quiet passes.
// Until kMinViews views were measured, or before the view's first iteration, every iteration
// runs `full` passes. Pure logic, no Vulkan: tests/test_sample_pacer.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

namespace mds::render {

class SamplePacer {
 public:
  static constexpr size_t kHistory = 16;  // views the reference is the median of
  static constexpr size_t kMinViews = 2;  // views measured before pacing starts
  // A view's pass may cost this much more than the reference before it loses a pass: the pass
  // times of ordinary views scatter by +-30 % around the median on lavapipe.
  static constexpr double kSlack = 1.25;

  // The per-pass GPU ms of an iteration at rest of the current view; ignores <= 0.
  void observe(double pass_ms);
  // The current view ends: its median joins the history (when it was measured).
  void new_view();
  // Passes of the next iteration at rest in a view whose last pass took view_pass_ms (<= 0:
  // not measured yet). Precondition: full >= 1 (0 is taken as 1).
  uint32_t passes(uint32_t full, double view_pass_ms) const;
  // The reference (0 while fewer than kMinViews views were measured).
  double reference_ms() const;

 private:
  std::vector<double> view_;    // this view's per-pass times
  std::deque<double> history_;  // per-view medians, oldest first
};

}  // namespace mds::render
