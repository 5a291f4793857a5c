// Dynamic resolution while the camera moves: a controller that picks the internal render scale
// (a fraction of the full width and height) from recent frame times against a target, so that
// frame time tracks the target instead of following the view's cost (docs/viewer.md "Dynamic
// resolution"). No Vulkan here: the viewer and `mdstream stress` apply the scale with
// Renderer::resize(); tests/test_frame_pacer.cpp drives it with synthetic frame times.
//
// The model. A moving frame is a new view (culling restarts, one culling iteration + draw); its
// cost on a rasterizer grows with the pixels p = s^2 (s = scale) sub-linearly: measured on
// lavapipe inside the porous scene (docs/viewer.md "Dynamic resolution") a frame at 1/4 of the pixels costs
// about 1/3, at 1/16 about 1/8, i.e. t ~ p^0.8. After a moving frame of time t at scale s the
// next scale is s * (target / t)^(0.5 / 0.8): one step lands near the target when the view's
// cost changes slowly, as it does along a camera path. Down-steps are taken at once (a slow
// frame is what the user sees), up-steps at most x1.25 per frame and only when the frame was
// faster than (1 - band) * target (no oscillation around the target). Scales are quantized to
// 1/16 (rounded down) so that small fluctuations do not resize the renderer every frame, and
// kept within [min_scale, max_scale].
// Trend: a camera entering dense data makes each view costlier than the last (on lavapipe by
// 3-5x per frame of a coarse path). Reacting to the last frame alone is then one frame late at
// every step, so the cost is normalized to full scale (c = t / s^(1/exponent)) and, when c grew
// from the previous moving frame, the growth (at most max_trend) is extrapolated one frame
// ahead; a falling cost is not extrapolated (up-steps stay cautious).
// Arrivals (streaming; observe()'s FrameLoad): a frame's time describes the nodes it drew; the
// nodes it wanted but lacked arrive within the next frames, drawn at the scale chosen now. So a
// frame that lacked more wanted nodes than it drew (and whose pool can hold them) raises no
// scale: on the cache benchmark's ablation fly-through a few views that drew next to nothing had
// let the scale climb to 1.0, then 4-16 near nodes arrived and that frame cost 2-3x the median
// (docs/viewer.md "Dynamic resolution", with a rule tried and not kept: lowering the scale ahead
// of the arrivals).
//
// Work the render size does not change (the split): only a frame's GPU time scales with the
// pixels; the rest of its wall time (CPU: culling bookkeeping, the cache, uploads, submission,
// the viewer's HUD and present) is fixed. observe() takes the frame's GPU time and applies the
// model to it alone: t = h + g, h = t - g fixed, g ~ s^(1/exponent). A down-step solves for the
// GPU time that fits the target beside h. When h alone exceeds the target no scale meets it:
// if g is at least a third of the frame the whole frame is priced by its pixels (as without the
// split: the smaller frame is the best there is), otherwise the scale is kept (resolution cannot
// buy the frame back). An up-step needs g below (1 - band) of the room beside h. Without a GPU
// time (0) the whole frame scales, as before.
// Where: on an H100 the cache benchmark's 320x180 fly-throughs sat at min_scale when the whole
// frame was priced by its pixels: a frame at 1/8 scale (porous p50 2.2 ms) cost nearly what one
// at full scale did (2.5 ms), and an up-step needed it under 0.85x the target. How much of that
// fixed part was CPU work, which the split takes out, was not measured there (docs/viewer.md
// "Dynamic resolution", docs/results/gpu-h100.md). On a CPU device (lavapipe) h is 5-20 % of a
// frame and the split is off by default (GpuSplit::gpu_devices): there it changed p99/p50 by no
// more than the noise, and in two A/B runs the porous fly-through's hit rate / Belady was 0.02
// lower with it (0.957 -> 0.940, 0.936 -> 0.916; two benchmark runs without it gave 0.959 and
// 0.936, so this is at the edge of the noise). Off, lavapipe behaves as before.
//
// Sampling follows the pixels (scale_samples, --pace-samples): a moving frame runs one occlusion
// sampling pass (Renderer::set_motion), whose cost is per occluder particle, not per pixel: at
// 1/8 scale the porous fly-through's pass still took 15-30 of its 30-40 ms on lavapipe, the
// frames could not reach the target at any scale, and the scale sat at min_scale. A smaller
// image needs fewer samples for the same samples per pixel, so the pass selects the render
// size's share of the pixels of the occluder budget (sample_share()), at least
// min_sample_share. Then the whole frame follows the pixels, as the model above assumes: the
// cache benchmark's dynamic fly-throughs went p99/p50 2.22 -> 1.86 (porous) and 1.85 -> 1.57
// (ablation), medians of 10 runs. The floor of 1/16 kept the porous hit rate / Belady near
// where it was (0.959 -> 0.948); without a floor it fell to 0.894 (docs/viewer.md "Dynamic
// resolution", "Sampling follows the pixels").
//
// The target. Fixed (--frame-ms-target MS), or automatic (0, default): auto_factor (1.25) times
// the median of the last auto_window moving frames rendered at full scale. The frames the
// camera costs least (outside the data, an overview) set the pace, and only views that would
// be slower than 1.25x that pace lose resolution; on a fast GPU the same rule holds at 1-10 ms.
// A target in ms that fits every machine does not exist (lavapipe needs ~0.3-1 s per view at
// 320x180, a GPU ~5 ms), hence the automatic default. Until the first full-scale moving frame
// has been seen there is no target and the scale stays at max_scale.
//
// At rest (the camera did not move) the scale is max_scale at once: the progressive refinement
// (culling convergence + super-sampling) always runs at full resolution.
#pragma once

#include <cstdint>
#include <deque>

namespace mds::render {

// What a moving frame drew against what it wanted (streaming: FrameReport::load(), from its
// frame_hits / frame_misses / budget_exhausted). All zero (in memory): no arrivals.
struct FrameLoad {
  uint32_t drawn = 0;      // wanted nodes resident (drawn by the frame)
  uint32_t missing = 0;    // wanted nodes not resident (reads queued or in flight)
  bool pool_full = false;  // the pool cannot hold every wanted node: not all of `missing` will arrive
};

// Where the split of the file comment applies (--pace-gpu-time auto|true|false).
enum class GpuSplit : uint8_t {
  gpu_devices,  // auto: on a GPU, not on a CPU device (PacerSettings::cpu_device)
  on,
  off,  // the whole frame scales
};

struct PacerSettings {
  double target_ms = 0.0;      // 0: automatic (see the file comment)
  double auto_factor = 1.25;   // automatic target = auto_factor x median full-scale moving frame
  uint32_t auto_window = 32;   // full-scale moving frames in that median
  double min_scale = 0.125;    // of width and height (1/64 of the pixels)
  double max_scale = 1.0;
  double quantum = 1.0 / 16.0; // scales are multiples of this (rounded down), except max_scale
  double band = 0.15;          // up-steps only below (1 - band) x target
  double max_up = 1.25;        // largest up-step factor per frame
  double exponent = 0.5 / 0.8; // s' = s * (target / t)^exponent (t ~ pixels^0.8)
  double max_trend = 4.0;      // cap of the growth extrapolated from the last two moving frames
  bool watch_arrivals = true;  // the arrival rule of the file comment (false: frame times only)
  GpuSplit gpu_split = GpuSplit::gpu_devices;  // the split of the file comment: where it applies
  bool cpu_device = false;     // the renderer's device is a CPU (lavapipe): set by the caller
  bool scale_samples = true;   // sample_share(): the occlusion sampling follows the pixels (file comment)
  double min_sample_share = 1.0 / 16.0;  // its floor (1/16 of the budget: scale 1/4 and below)
};

class FramePacer {
 public:
  explicit FramePacer(PacerSettings settings = {});

  // The scale of the next frame: the controller's for a moving frame, max_scale at rest.
  double next_scale(bool moving);
  // The frame rendered at the scale next_scale() returned took frame_ms (wall time of the
  // whole frame), gpu_ms of it on the GPU (its own passes, Renderer::last_frame_gpu() after
  // finish(); 0: unknown, the whole frame scales), and drew `load`; a moving frame updates the
  // controller (and the automatic target, which stays in wall time).
  void observe(double frame_ms, const FrameLoad& load = {}, double gpu_ms = 0.0);

  double scale() const { return scale_; }          // controller's scale for moving frames
  double last_scale() const { return last_scale_; }  // what next_scale() returned last
  double target_ms() const;                         // 0 while the automatic target is unknown
  const PacerSettings& settings() const { return s_; }
  bool split_gpu_time() const;  // the split applies (settings' gpu_split and cpu_device)

  // The share of the culling loop's occluder budget that the sampling pass of the frame at
  // last_scale() selects (Renderer::set_motion): the scaled size's share of the pixels of
  // width x height, at least min_sample_share; 1 when scale_samples is off or at full scale.
  double sample_share(uint32_t width, uint32_t height) const;
  // width/height x scale, rounded, at least 1 pixel (and exactly w x h at scale >= 1).
  static void scaled_size(uint32_t width, uint32_t height, double scale, uint32_t& out_w, uint32_t& out_h);

 private:
  double quantize(double s) const;
  PacerSettings s_;
  double scale_ = 1.0;
  double last_scale_ = 1.0;
  bool last_moving_ = false;
  double last_cost_ = 0.0;  // full-scale-normalized GPU cost of the previous moving frame (0: none)
  std::deque<double> full_scale_ms_;  // recent full-scale moving frames (automatic target)
};

}  // namespace mds::render
