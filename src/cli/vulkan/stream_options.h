// The streaming-cache options shared by `render`, `view` and `stress` (--gpu-budget and the I/O
// and policy knobs of docs/streaming.md): one set of names, defaults, help texts and checks.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/result.h"
#include "render/frame_pacer.h"
#include "render/renderer.h"

namespace mds::cli {

struct StreamOptions {
  std::string gpu_budget;  // empty: in memory (render, view)
  std::string policy = "occlusion";
  unsigned io_threads = 2;
  double io_latency_ms = 0.0;
  std::string io_bandwidth;  // empty: unlimited
  std::string upload_per_frame = "32MiB";
  uint32_t max_outstanding = 128;
  double moving_waste_share = 0.5;  // render::StreamSettings::moving_waste_share
  uint32_t wave_settle_frames = 2;  // render::StreamSettings::wave_settle_frames
  uint32_t wave_nodes = 2;          // render::StreamSettings::wave_nodes
  double wave_coverage = 1.0;       // render::StreamSettings::wave_coverage
  bool front_node_alone = true;     // render::StreamSettings::front_node_alone
  bool keep_late_arrivals = true;   // render::StreamSettings::keep_late_arrivals
  uint32_t occluded_hold_frames = 1;  // render::StreamSettings::occluded_hold_frames
  std::string series_first_wave = "prior";  // prior|cold: render::StreamSettings::carry_view
};

// Adds --gpu-budget (required when budget_required) and the others; --series-first-wave only for
// the commands that take a series (`series`).
void add_stream_options(CLI::App& sub, StreamOptions& o, bool budget_required, bool series);
// The settings; Errc::invalid_argument naming the option for a bad value. Precondition:
// !o.gpu_budget.empty().
Result<render::StreamSettings> stream_settings(const StreamOptions& o);

// What a user of a streaming render must know about its cache, one sentence each (empty when
// nothing): the device's limits made the pool smaller than --gpu-budget, and the last frame
// wanted more nodes than the pool holds (the image lacks those that did not fit).
// max_storage_range: the device's maxStorageBufferRange.
std::vector<std::string> cache_warnings(const render::CacheStats& c, uint64_t max_storage_range);

// Dynamic resolution while the camera moves (render/frame_pacer.h), shared by `view` (on by
// default) and `stress` (off by default).
struct PacingOptions {
  bool dynamic = false;
  double frame_ms_target = 0.0;  // 0: automatic
  double min_scale = 0.125;
  bool watch_arrivals = true;  // render::PacerSettings::watch_arrivals
  bool scale_samples = true;   // render::PacerSettings::scale_samples
  std::string pace_gpu_time = "auto";  // render::PacerSettings::gpu_split: auto|true|false
};

// Adds --dynamic-resolution/--fixed-resolution (default: default_on), --frame-ms-target, --min-scale,
// --pace-arrivals, --pace-samples, --pace-gpu-time.
void add_pacing_options(CLI::App& sub, PacingOptions& o, bool default_on);
// The controller's settings; Errc::invalid_argument naming the option for a bad value.
Result<render::PacerSettings> pacer_settings(const PacingOptions& o);

}  // namespace mds::cli
