// Adaptive read window of the streaming cache (issue 4): how many node reads may be queued or in
// flight at a time. Shaped like TCP's congestion window (Jacobson, "Congestion avoidance and
// control", 1988: additive increase / multiplicative decrease, slow start), with waste = a read
// that arrived for a node found occluded meanwhile. Why a window at all: Ibrahim et al. §5
// (paper 000) classify occluders progressively; a node classified O before it was ever loaded is
// never read, so at rest the first arrivals must be sampled as occluders before more is read
// (Grottel et al. §3.1: front-to-back loading, the previous view's visible data occlude first).
//   at rest (a held view, or the first): the window restarts at `min` with each view, grows by
//     `min` after `calm_frames` frames whose arrivals were all still wanted, and is halved (not
//     below `min`) after a frame with waste;
//   while the camera moves (the previous view ran at most one frame): every frame is a new view
//     whose classes never mature, so waiting for them gains nothing and a window restarted per
//     view could never grow. When the motion starts the window opens to `cap`; across the moving
//     views it keeps its state, halved after a frame where at least `moving_waste_share` of the
//     arrivals were waste, doubled after one with less. A moving view's classes come from one
//     culling iteration, in which a node flips between O and P from frame to frame: a few of a
//     frame's arrivals found O is that noise, not a window too wide (docs/streaming.md).
// Pure logic, no threads; tests/test_streaming_window.cpp.
#pragma once

#include <cstdint>

namespace mds::streaming {

struct ReadWindowSettings {
  uint32_t min = 4;          // window at the start of a held view; additive step
  uint32_t calm_frames = 3;  // calm frames (arrivals, no waste) before an additive step at rest
  uint32_t cap = 64;         // largest window (--max-outstanding)
  // While moving: the share of a frame's arrivals that must be waste to halve the window
  // (--moving-waste-share; 0: any waste halves it, as at rest).
  double moving_waste_share = 0.5;
};

// Share of the image that a node's bounding sphere covers: a disk of radius `projected_size` (in
// half image heights, ResidencyTable's projected_size) on an image `aspect` = width / height wide,
// pi p^2 / (4 aspect), at most 1 (a node around the eye covers the image once). The size of a
// wave at rest (StreamSettings::wave_coverage) is counted in these shares.
double screen_share(double projected_size, double aspect);

class ReadWindow {
 public:
  explicit ReadWindow(ReadWindowSettings settings = {});

  // A new view begins (camera change or restart). Decides from the length of the previous view
  // whether the camera moves, or takes `known_moving` from a caller that knows the camera's
  // next views (a camera path replay: the view is moving from its first frame, so a path that
  // starts cold opens the window at its first frame instead of its second).
  void new_view(bool known_moving = false);
  // The end of a frame's placement: `arrived` reads finished, `wasted` of them for nodes found
  // occluded meanwhile. Call once per frame.
  void end_frame(uint32_t arrived, uint32_t wasted);

  uint32_t size() const { return window_; }
  bool moving() const { return moving_; }
  const ReadWindowSettings& settings() const { return s_; }

 private:
  ReadWindowSettings s_;
  uint32_t window_;
  uint32_t calm_ = 0;           // calm frames since the window last changed
  uint32_t view_frames_ = 0;    // frames of the current view
  bool has_view_ = false;
  bool moving_ = false;
};

}  // namespace mds::streaming
