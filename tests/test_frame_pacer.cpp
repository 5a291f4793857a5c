// The dynamic-resolution controller (render/frame_pacer.h) on synthetic frame times: a cost
// model t = fixed + k * view_cost * pixels^0.8 stands in for the renderer. Checks: it converges
// to the target, never leaves [min_scale, max_scale], returns to full scale when the camera
// rests, derives the automatic target from full-scale moving frames, and brings the frame times
// of a view whose cost jumps back under the target within a few frames; streaming arrivals
// (FrameLoad) hold the scale; only the frame's GPU time is priced by its pixels; the occlusion
// sampling's share of the budget follows the pixels.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "render/frame_pacer.h"

using mds::render::FrameLoad;
using mds::render::FramePacer;
using mds::render::PacerSettings;

namespace {

// Frame time of a view of relative cost `view_cost` rendered at `scale`.
double model_ms(double view_cost, double scale, double fixed = 5.0) {
  return fixed + 100.0 * view_cost * std::pow(scale * scale, 0.8);
}

}  // namespace

TEST(FramePacer, ConvergesToAFixedTargetAndStaysInBounds) {
  PacerSettings ps;
  ps.target_ms = 40.0;
  FramePacer p(ps);
  double t = 0.0;
  for (int f = 0; f < 30; ++f) {
    const double s = p.next_scale(true);
    EXPECT_GE(s, ps.min_scale);
    EXPECT_LE(s, ps.max_scale);
    t = model_ms(1.0, s);
    p.observe(t);
  }
  // Full scale costs 105 ms; the controller settles where a frame meets the target, within a
  // quantum of the best scale (never above the target by more than the band's worth).
  EXPECT_LE(t, 40.0 * 1.15);
  EXPECT_GT(t, 40.0 * 0.5);
  EXPECT_LT(p.scale(), 1.0);
  // Stable: no resize once settled.
  const double settled = p.scale();
  for (int f = 0; f < 10; ++f) {
    p.next_scale(true);
    p.observe(model_ms(1.0, settled));
  }
  EXPECT_EQ(p.scale(), settled);
}

TEST(FramePacer, NeverLeavesTheBoundsEvenForExtremeTimes) {
  PacerSettings ps;
  ps.target_ms = 10.0;
  ps.min_scale = 0.3;
  ps.max_scale = 0.9;
  FramePacer p(ps);
  const double times[] = {1e6, 1e-3, 5e4, 0.0, -3.0, std::nan(""), 1e9, 0.5, 0.5, 0.5, 0.5, 0.5};
  for (double t : times) {
    const double s = p.next_scale(true);
    EXPECT_GE(s, 0.3 - 1e-12);
    EXPECT_LE(s, 0.9 + 1e-12);
    p.observe(t);
  }
  EXPECT_GE(p.scale(), 0.3 - 1e-12);
  EXPECT_LE(p.scale(), 0.9 + 1e-12);
  EXPECT_EQ(p.next_scale(false), 0.9);  // rest: the largest scale allowed
}

TEST(FramePacer, ReturnsToFullScaleWhenTheCameraRests) {
  PacerSettings ps;
  ps.target_ms = 20.0;
  FramePacer p(ps);
  for (int f = 0; f < 10; ++f) p.observe((p.next_scale(true), model_ms(2.0, p.last_scale())));
  ASSERT_LT(p.scale(), 1.0);
  EXPECT_EQ(p.next_scale(false), 1.0);
  p.observe(model_ms(2.0, 1.0));  // a resting frame does not teach the controller
  EXPECT_EQ(p.next_scale(false), 1.0);
  EXPECT_LT(p.next_scale(true), 1.0);  // moving again resumes at the controller's scale
}

TEST(FramePacer, AutomaticTargetFollowsFullScaleMovingFrames) {
  FramePacer p;  // target 0: automatic
  EXPECT_EQ(p.target_ms(), 0.0);
  // Cheap views at full scale: no target exceeded, full scale kept; target auto_factor x their median.
  for (int f = 0; f < 8; ++f) {
    EXPECT_EQ(p.next_scale(true), 1.0);
    p.observe(100.0 + f);  // 100..107 ms
  }
  EXPECT_NEAR(p.target_ms(), PacerSettings{}.auto_factor * 103.5, 1e-9);
  EXPECT_EQ(p.scale(), 1.0);
  // A view 10x as costly: the scale drops at once and the following frames meet the target.
  std::vector<double> times;
  for (int f = 0; f < 8; ++f) {
    const double s = p.next_scale(true);
    const double t = model_ms(10.0, s, 0.0);  // 1000 ms at full scale
    times.push_back(t);
    p.observe(t);
  }
  EXPECT_GT(times[0], 900.0);  // the jump itself is seen once at full scale
  for (size_t f = 2; f < times.size(); ++f) EXPECT_LE(times[f], 1.15 * p.target_ms()) << "frame " << f;
  // Frames at reduced scale do not move the automatic target; the full-scale frame of the jump
  // joined the median window: median of 100..107 and 1000 = 104.
  EXPECT_NEAR(p.target_ms(), PacerSettings{}.auto_factor * 104.0, 1e-9);
}

TEST(FramePacer, RisingCostIsAnticipated) {
  // A camera flying into dense data: the view's cost grows by 1.6x per frame. Extrapolating the
  // trend keeps the frames near the target; without it each frame would overshoot by 1.6x.
  PacerSettings ps;
  ps.target_ms = 50.0;
  ps.min_scale = 1.0 / 16.0;
  FramePacer p(ps);
  double cost = 0.3;
  int over = 0;
  for (int f = 0; f < 12; ++f) {
    const double t = model_ms(cost, p.next_scale(true), 0.0);
    if (f >= 3 && t > 1.3 * ps.target_ms) ++over;
    p.observe(t);
    cost *= 1.6;
  }
  EXPECT_EQ(over, 0);
}

// The growth of the scale over `frames` cheap moving frames (10 ms against a 40 ms target) that
// each drew `load`, from the scale a 400 ms full-scale frame led to ((40 / 400)^0.625 = 0.24,
// rounded down to 3/16).
static double scale_after_cheap_frames(const FrameLoad& load, int frames, bool watch_arrivals = true) {
  PacerSettings ps;
  ps.target_ms = 40.0;
  ps.watch_arrivals = watch_arrivals;
  FramePacer p(ps);
  p.next_scale(true);
  p.observe(model_ms(1.0, 1.0, 0.0) * 4.0);  // 400 ms at full scale
  const double start = p.scale();
  EXPECT_LT(start, 0.25);
  for (int f = 0; f < frames; ++f) {
    p.next_scale(true);
    p.observe(10.0, load);
  }
  return p.scale() / start;  // growth of the scale
}

TEST(FramePacer, AFrameLackingMostOfItsNodesRaisesNoScale) {
  // Lacking more wanted nodes than it drew: its cost says little about the next frames, which
  // draw the arrivals. Held (the pool can hold them) ...
  EXPECT_EQ(scale_after_cheap_frames({.drawn = 3, .missing = 20}, 6), 1.0);
  // ... raised once it drew most of what it wanted, when the pool is full (the rest will not
  // arrive), and without the arrival rules.
  EXPECT_GT(scale_after_cheap_frames({.drawn = 20, .missing = 3}, 6), 1.5);
  EXPECT_GT(scale_after_cheap_frames({.drawn = 3, .missing = 20, .pool_full = true}, 6), 1.5);
  EXPECT_GT(scale_after_cheap_frames({.drawn = 3, .missing = 20}, 6, false), 1.5);
  EXPECT_GT(scale_after_cheap_frames({}, 6), 1.5);  // in memory: no arrivals
}

// A GPU-like frame: h ms of CPU work that the render size does not change, and g_full ms of GPU
// work at full scale that scales with the pixels (as model_ms). Runs 40 moving frames against a
// 2.25 ms target; returns the last scale, the last frame's time in *last_ms.
static double scale_with_fixed_cpu(double h, double g_full, bool split, double* last_ms) {
  PacerSettings ps;
  ps.target_ms = 2.25;
  ps.gpu_split = split ? mds::render::GpuSplit::on : mds::render::GpuSplit::off;
  FramePacer p(ps);
  for (int f = 0; f < 40; ++f) {
    const double g = g_full * std::pow(std::pow(p.next_scale(true), 2.0), 0.8);
    *last_ms = h + g;
    p.observe(h + g, {}, g);
  }
  return p.scale();
}

TEST(FramePacer, ScalesOnlyTheFramesGpuTime) {
  // 2.1 ms of CPU work, 0.5 ms of GPU at full scale (the H100's 320x180 cache benchmark frames
  // are ~2 ms of wall time for 0.2-0.5 ms of GPU). Priced by its GPU time, the frame meets the
  // target at the largest scale whose GPU time fits beside the CPU's 2.1 ms ...
  // (0.15 ms of GPU: s^1.6 <= 0.3, s <= 0.47; on the 1/16 grid 7/16), or one quantum below it.
  double t = 0.0;
  const double split = scale_with_fixed_cpu(2.1, 0.5, true, &t);
  EXPECT_LE(t, 2.25);
  EXPECT_LE(split, 7.0 / 16.0);
  EXPECT_GE(split, 6.0 / 16.0);
  // ... where a frame priced whole by its pixels falls to min_scale: every step down leaves it
  // above the target or inside the band below it, where no up-step is taken.
  EXPECT_EQ(scale_with_fixed_cpu(2.1, 0.5, false, &t), PacerSettings{}.min_scale);
  // CPU work alone above the target: no scale can meet it, full scale is kept.
  EXPECT_EQ(scale_with_fixed_cpu(2.4, 0.5, true, &t), 1.0);
  EXPECT_EQ(scale_with_fixed_cpu(2.4, 0.5, false, &t), PacerSettings{}.min_scale);
  // The default (--pace-gpu-time auto) splits on a GPU only.
  EXPECT_TRUE(FramePacer(PacerSettings{}).split_gpu_time());
  EXPECT_FALSE(FramePacer(PacerSettings{.cpu_device = true}).split_gpu_time());
  EXPECT_TRUE(FramePacer(PacerSettings{.gpu_split = mds::render::GpuSplit::on, .cpu_device = true}).split_gpu_time());
  // All of the frame on the GPU (lavapipe runs the GPU work on the CPU cores; a frame's GPU time
  // is 80-95 % of its wall time there): the split changes nothing.
  double t_split = 0.0, t_whole = 0.0;
  EXPECT_EQ(scale_with_fixed_cpu(0.0, 8.0, true, &t_split), scale_with_fixed_cpu(0.0, 8.0, false, &t_whole));
  EXPECT_EQ(t_split, t_whole);
}

TEST(FramePacer, ScaledSizeRoundsAndKeepsAtLeastOnePixel) {
  uint32_t w = 0, h = 0;
  FramePacer::scaled_size(320, 180, 1.0, w, h);
  EXPECT_EQ(w, 320u);
  EXPECT_EQ(h, 180u);
  FramePacer::scaled_size(320, 180, 0.5, w, h);
  EXPECT_EQ(w, 160u);
  EXPECT_EQ(h, 90u);
  FramePacer::scaled_size(320, 180, 0.0625, w, h);
  EXPECT_EQ(w, 20u);
  EXPECT_EQ(h, 11u);
  FramePacer::scaled_size(3, 2, 0.01, w, h);
  EXPECT_EQ(w, 1u);
  EXPECT_EQ(h, 1u);
}

// The occlusion sampling follows the pixels (PacerSettings::scale_samples): a moving frame at a
// reduced scale samples the scaled size's share of the pixels of the budget, at least
// min_sample_share; full scale, frames at rest, and the option off keep the whole budget.
TEST(FramePacer, SamplingShareFollowsThePixels) {
  PacerSettings ps;
  ps.target_ms = 10.0;
  FramePacer p(ps);
  EXPECT_EQ(p.next_scale(true), 1.0);
  EXPECT_EQ(p.sample_share(320, 180), 1.0);
  // A frame at 4x the target: the scale falls; the share is the scaled size's pixels.
  p.observe(40.0);
  const double s = p.next_scale(true);
  ASSERT_LT(s, 1.0);
  ASSERT_GT(s, 0.25);
  uint32_t w = 0, h = 0;
  FramePacer::scaled_size(320, 180, s, w, h);
  EXPECT_DOUBLE_EQ(p.sample_share(320, 180), double(w) * h / (320.0 * 180.0));
  // Far over the target: min_scale (1/8, 40x22 = 1.5 % of the pixels) samples the floor, 1/16.
  for (int i = 0; i < 8; ++i) {
    p.observe(1000.0);
    p.next_scale(true);
  }
  ASSERT_EQ(p.last_scale(), ps.min_scale);
  EXPECT_DOUBLE_EQ(p.sample_share(320, 180), ps.min_sample_share);
  PacerSettings no_floor = ps;
  no_floor.min_sample_share = 0.0;
  FramePacer q(no_floor);
  q.next_scale(true);
  for (int i = 0; i < 8; ++i) {
    q.observe(1000.0);
    q.next_scale(true);
  }
  EXPECT_DOUBLE_EQ(q.sample_share(320, 180), 40.0 * 23.0 / (320.0 * 180.0));
  // At rest the full size and the whole budget return.
  EXPECT_EQ(p.next_scale(false), 1.0);
  EXPECT_EQ(p.sample_share(320, 180), 1.0);
  // Off: the whole budget at every scale.
  PacerSettings off = ps;
  off.scale_samples = false;
  FramePacer r(off);
  r.next_scale(true);
  r.observe(1000.0);
  ASSERT_LT(r.next_scale(true), 1.0);
  EXPECT_EQ(r.sample_share(320, 180), 1.0);
}
