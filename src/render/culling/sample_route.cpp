// The automatic choice between the occlusion sampling pass's two routes (sample_route.h): the
// comparison, the probe and the slowed-pass trigger, decided from GPU timings alone.
#include "render/culling/sample_route.h"

#include <algorithm>
#include <cmath>

namespace mds::render::culling {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return -1.0;
  const size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + ptrdiff_t(h), v.end());
  if (v.size() % 2) return v[h];
  const double hi = v[h];
  return 0.5 * (*std::max_element(v.begin(), v.begin() + ptrdiff_t(h)) + hi);
}

}  // namespace

uint32_t sample_route_probe_share(double winner_ms, double other_ms, bool moving) {
  if (moving) return kSampleRouteMovingProbeShare;
  if (!(winner_ms > 0.0) || !(other_ms > 0.0)) return kSampleRouteProbeShare;
  const double share = std::ceil(other_ms / winner_ms / kSampleRouteProbeCost);
  return uint32_t(std::clamp(share, double(kSampleRouteProbeShare), double(kSampleRouteMovingProbeShare)));
}

int sample_route_clear_winner(std::span<const double> raster_ms, std::span<const double> compute_ms) {
  if (raster_ms.empty() || compute_ms.empty()) return -1;
  const auto [r_lo, r_hi] = std::minmax_element(raster_ms.begin(), raster_ms.end());
  const auto [c_lo, c_hi] = std::minmax_element(compute_ms.begin(), compute_ms.end());
  if (*c_lo >= kSampleRouteClearCut * *r_hi) return 0;
  if (*r_lo >= kSampleRouteClearCut * *c_hi) return 1;
  return -1;
}

bool sample_route_run_slowed(double pass_ms, double running_compared_ms, double other_compared_ms) {
  return pass_ms > kSampleRouteClearCut * running_compared_ms && pass_ms > other_compared_ms;
}

void SampleRouteChooser::begin_iteration(bool moving) {
  if (!comparing_ && moving && (best_ < 0 || trigger_)) {
    // While the camera moves a comparison is one probe (kSampleRouteMovingHysteresis): the
    // running route -- compute when none has won yet -- samples, and one pass of the other route
    // over 1/probe_share() of the budget is timed.
    if (best_ < 0) best_ = kCompute;
    comparing_ = true;
    probing_ = true;
    moving_comparison_ = true;
    compare_[0].clear();
    compare_[1].clear();
    probe_estimate_ = false;
  } else if (!comparing_ && !moving && (best_ < 0 || trigger_ || since_compare_ >= explore_interval_)) {
    // A repeat comparison starts as a probe, whatever the pass count: with one pass per iteration
    // (paced sampling at rest, render/sample_pacer.h) an alternating comparison would run whole
    // passes of the slower route.
    comparing_ = true;
    probing_ = best_ >= 0;
    moving_comparison_ = false;
    // Started by a slowed pass: the probe's share follows that pass, not the last comparison.
    running_ms_ = trigger_ ? trigger_ms_ : (best_ >= 0 ? compared_[best_] : -1.0);
    since_compare_ = 0;
    compare_[0].clear();
    compare_[1].clear();
    probe_estimate_ = false;
  }
  trigger_ = false;
  trigger_ms_ = -1.0;
  ++since_compare_;
}

void SampleRouteChooser::stop() {
  comparing_ = false;
  probing_ = false;
}

uint32_t SampleRouteChooser::probe_share() const {
  const double other = best_ < 0 ? -1.0 : compared_[1 - best_];
  return sample_route_probe_share(best_ < 0 ? -1.0 : running_ms_, other, moving_comparison_);
}

int SampleRouteChooser::pass_route(uint32_t p, uint32_t pass_count) const {
  if (comparing_) {
    if (probing_) return best_;  // the probe of the other route is an extra pass
    if (pass_count >= 2) return p % 2 == 0 ? kCompute : kRaster;
    // One pass per iteration: alternate, the route with fewer timed passes first; on a tie the
    // probed route while its estimate stands (a whole pass replaces it: after a probe that
    // decided nothing), else compute in a first comparison and the winner in a repeat.
    if (compare_[0].size() != compare_[1].size()) return compare_[1].size() < compare_[0].size() ? kCompute : kRaster;
    if (probe_estimate_) return 1 - best_;
    return best_ < 0 ? kCompute : best_;
  }
  return best_ != kRaster ? kCompute : kRaster;
}

void SampleRouteChooser::collect(std::span<const Timing> timings) {
  if (!comparing_) {
    // The running route's passes: a slowed one starts the next iteration's comparison.
    if (best_ < 0) return;
    for (const Timing& t : timings)
      if (t.kind == Kind::run && sample_route_run_slowed(t.ms, compared_[best_], compared_[1 - best_])) {
        trigger_ = true;
        trigger_ms_ = std::max(trigger_ms_, t.ms);
      }
    return;
  }
  bool any = false;
  for (const Timing& t : timings) {
    if (t.kind == Kind::run || t.route < 0 || t.route > 1) continue;
    if (t.kind == Kind::compared && probe_estimate_ && t.route == 1 - best_ && !compare_[t.route].empty()) {
      // A whole pass of the probed route replaces the probe's estimate (high: the pass's fixed
      // cost counted share times; on the H200 a 1/16 raster probe counted 2.2-2.5 ms for a
      // 0.24 ms pass).
      compare_[t.route].erase(compare_[t.route].begin());
      probe_estimate_ = false;
    }
    compare_[t.route].push_back(t.ms);
    if (t.kind == Kind::probe) probe_estimate_ = true;
    any = true;
  }
  if (!any) return;  // the iteration was not timed: decide after the next one
  const int best = best_, other = 1 - best_;
  if (probing_ && moving_comparison_) {
    // A moving comparison (decided here even when the camera has stopped since): the probed
    // route takes over when its estimate beats the running route's passes by
    // kSampleRouteMovingHysteresis (no whole passes of a slower route).
    probing_ = false;
    comparing_ = false;
    moving_comparison_ = false;
    if (compare_[0].empty() || compare_[1].empty()) return;  // not timed: try again later
    compared_[best] = median(compare_[best]);
    compared_[other] = median(compare_[other]);
    if (kSampleRouteMovingHysteresis * compared_[other] < compared_[best]) best_ = other;
    return;
  }
  if (probing_) {
    probing_ = false;
    const int clear = sample_route_clear_winner(compare_[0], compare_[1]);
    if (clear >= 0) {
      // Clear-cut either way: the winner stays (the interval doubles) or the probed route takes over.
      compared_[0] = median(compare_[0]);
      compared_[1] = median(compare_[1]);
      comparing_ = false;
      explore_interval_ = clear == best ? std::min(2 * explore_interval_, kSampleRouteExploreMax) : kSampleRouteExplore;
      best_ = clear;
      return;
    }
    // Not clear-cut: the comparison continues with alternating passes (the probe's samples count).
  }
  const bool full = compare_[0].size() >= kSampleRouteCompare && compare_[1].size() >= kSampleRouteCompare;
  const bool early = compare_[0].size() >= kSampleRouteEarly && compare_[1].size() >= kSampleRouteEarly &&
                     sample_route_clear_winner(compare_[0], compare_[1]) >= 0;
  if (full || early) {
    for (int r = 0; r < 2; ++r) compared_[r] = median(compare_[r]);
    const int previous = best_;
    best_ = compared_[kCompute] <= compared_[kRaster] ? kCompute : kRaster;
    comparing_ = false;
    explore_interval_ = early && best_ == previous ? std::min(2 * explore_interval_, kSampleRouteExploreMax)
                                                   : kSampleRouteExplore;
  }
}

}  // namespace mds::render::culling
