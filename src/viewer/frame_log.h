// --frame-log: one CSV row per displayed frame (the viewer benchmark's input,
// tools/bench_viewer.py). Written to "<path>.tmp.<pid>" and renamed when the viewer exits.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "core/result.h"
#include "render/renderer.h"

namespace mds::viewer {

struct FrameLogRow {
  uint32_t frame = 0;
  double t_ms = 0.0;       // since the loop started
  double frame_ms = 0.0;   // wall time of the whole loop iteration (events, step, readback, HUD, present)
  double step_ms = 0.0;    // Renderer::step() + read_image()
  bool stepped = false;    // false: idle (converged), only re-presented
  bool camera_moved = false;
  render::FrameReport report;
  render::CacheStats cache;
  double scale = 1.0;                          // dynamic resolution: render scale of this frame
  uint32_t render_width = 0, render_height = 0;  // the renderer's size this frame
  int64_t series_frame = -1;  // a series: the frame shown after this one (-1: no series)
  double reload_ms = 0.0;     // of frame_ms: loading a store, slices or a threshold (series step, slice or threshold keys)
  bool held = false;          // the image shown is the frame before's (a series step streaming)
};

class FrameLog {
 public:
  static Result<std::unique_ptr<FrameLog>> open(const std::filesystem::path& path);
  ~FrameLog();
  void add(const FrameLogRow& row);
  Status commit();  // closes and renames into place

 private:
  FrameLog() = default;
  std::filesystem::path path_, tmp_;
  std::FILE* f_ = nullptr;
};

}  // namespace mds::viewer
