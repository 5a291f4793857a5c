// Adaptive read window (AIMD / slow start); see read_window.h.
#include "streaming/read_window.h"

#include <algorithm>
#include <numbers>

namespace mds::streaming {

double screen_share(double projected_size, double aspect) {
  if (!(projected_size > 0.0) || !(aspect > 0.0)) return 0.0;
  return std::min(1.0, std::numbers::pi * projected_size * projected_size / (4.0 * aspect));
}

ReadWindow::ReadWindow(ReadWindowSettings settings) : s_(settings) {
  s_.cap = std::max(1u, s_.cap);
  s_.min = std::clamp(s_.min, 1u, s_.cap);
  s_.calm_frames = std::max(1u, s_.calm_frames);
  window_ = s_.min;
}

void ReadWindow::new_view(bool known_moving) {
  const bool moving = known_moving || (has_view_ && view_frames_ <= 1);
  if (!moving) {
    window_ = s_.min;
    calm_ = 0;
  } else if (!moving_) {  // the camera starts moving
    window_ = s_.cap;
    calm_ = 0;
  }
  moving_ = moving;
  has_view_ = true;
  view_frames_ = 0;
}

void ReadWindow::end_frame(uint32_t arrived, uint32_t wasted) {
  ++view_frames_;
  // Moving: a share of waste below moving_waste_share is the noise of one-iteration classes.
  if (moving_ && wasted > 0 && double(wasted) < s_.moving_waste_share * double(arrived)) wasted = 0;
  if (wasted > 0) {
    window_ = std::max(s_.min, window_ / 2);
    calm_ = 0;
  } else if (arrived > 0 && ++calm_ >= (moving_ ? 1u : s_.calm_frames)) {
    window_ = std::min(s_.cap, moving_ ? window_ * 2 : window_ + s_.min);
    calm_ = 0;
  }
}

}  // namespace mds::streaming
