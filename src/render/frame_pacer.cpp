// Dynamic-resolution controller; see frame_pacer.h for the model and the target.
#include "render/frame_pacer.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mds::render {

FramePacer::FramePacer(PacerSettings settings) : s_(settings) {
  s_.max_scale = std::clamp(s_.max_scale, 1e-3, 1.0);
  s_.min_scale = std::clamp(s_.min_scale, 1e-3, s_.max_scale);
  if (!(s_.quantum > 0.0)) s_.quantum = 1.0 / 16.0;
  if (s_.auto_window == 0) s_.auto_window = 1;
  if (!(s_.max_up > 1.0)) s_.max_up = 1.25;
  scale_ = last_scale_ = s_.max_scale;
}

double FramePacer::target_ms() const {
  if (s_.target_ms > 0.0) return s_.target_ms;
  if (full_scale_ms_.empty()) return 0.0;
  std::vector<double> v(full_scale_ms_.begin(), full_scale_ms_.end());
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  double med = v[v.size() / 2];
  if (v.size() % 2 == 0) {
    const double lo = *std::max_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2));
    med = 0.5 * (med + lo);
  }
  return s_.auto_factor * med;
}

bool FramePacer::split_gpu_time() const {
  return s_.gpu_split == GpuSplit::on || (s_.gpu_split == GpuSplit::gpu_devices && !s_.cpu_device);
}

double FramePacer::quantize(double s) const {
  if (s >= s_.max_scale) return s_.max_scale;
  const double q = std::floor(s / s_.quantum + 1e-9) * s_.quantum;
  return std::clamp(q, s_.min_scale, s_.max_scale);
}

double FramePacer::next_scale(bool moving) {
  last_moving_ = moving;
  last_scale_ = moving ? scale_ : s_.max_scale;
  return last_scale_;
}

void FramePacer::observe(double frame_ms, const FrameLoad& load, double gpu_ms) {
  if (!last_moving_) {
    last_cost_ = 0.0;  // a rest breaks the trend
    return;
  }
  if (!(frame_ms > 0.0) || !std::isfinite(frame_ms)) return;
  if (last_scale_ >= s_.max_scale && s_.target_ms <= 0.0) {
    full_scale_ms_.push_back(frame_ms);
    while (full_scale_ms_.size() > s_.auto_window) full_scale_ms_.pop_front();
  }
  const double s = last_scale_;
  // The split (file comment): g scales with the pixels, h does not.
  const bool split = split_gpu_time() && gpu_ms > 0.0 && std::isfinite(gpu_ms);
  const double g = split ? std::min(gpu_ms, frame_ms) : frame_ms;
  const double h = frame_ms - g;
  const double cost = g / std::pow(s, 1.0 / s_.exponent);
  const double trend = last_cost_ > 0.0 ? std::clamp(cost / last_cost_, 1.0, s_.max_trend) : 1.0;
  last_cost_ = cost;
  const double target = target_ms();
  if (target <= 0.0) return;
  const double expect_g = g * trend;  // the next frame's GPU time at scale s
  const double expect = h + expect_g;
  const double room = target - h;     // the GPU time that fits the target beside h
  // Arrivals (file comment): the lacking nodes will be drawn at the scale chosen now.
  const bool hold = s_.watch_arrivals && !load.pool_full && load.missing > load.drawn;  // no up-step
  double next = s;
  if (expect > target) {
    if (room > 0.0) next = s * std::pow(room / expect_g, s_.exponent);
    else if (3.0 * expect_g >= expect) next = s * std::pow(target / expect, s_.exponent);  // whole frame
    else return;  // h alone exceeds the target and g is a small part: a smaller frame does not help
  } else if (hold) {
    return;
  } else if (expect_g < (1.0 - s_.band) * room) {
    next = std::min(s * std::pow(room / expect_g, s_.exponent), s * s_.max_up);
  }
  // Rounding down must not swallow every up-step smaller than a quantum: one quantum up when
  // the model predicts it still meets the target.
  double q = quantize(next);
  if (next > s && q <= s && s < s_.max_scale) {
    const double up = quantize(std::min(s + s_.quantum, s_.max_scale));
    if (up > s && h + expect_g * std::pow(up / s, 1.0 / s_.exponent) <= target) q = up;
  }
  scale_ = std::clamp(q, s_.min_scale, s_.max_scale);
}

double FramePacer::sample_share(uint32_t width, uint32_t height) const {
  if (!s_.scale_samples || last_scale_ >= 1.0 || width == 0 || height == 0) return 1.0;
  uint32_t w = 0, h = 0;
  scaled_size(width, height, last_scale_, w, h);
  const double share = double(w) * double(h) / (double(width) * double(height));
  return std::clamp(std::max(share, s_.min_sample_share), 0.0, 1.0);
}

void FramePacer::scaled_size(uint32_t width, uint32_t height, double scale, uint32_t& out_w, uint32_t& out_h) {
  if (scale >= 1.0) {
    out_w = width;
    out_h = height;
    return;
  }
  out_w = std::max<uint32_t>(1, uint32_t(std::lround(double(width) * scale)));
  out_h = std::max<uint32_t>(1, uint32_t(std::lround(double(height) * scale)));
}

}  // namespace mds::render
