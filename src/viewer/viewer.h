// `mdstream view`: the interactive streaming viewer (issue 5). A GLFW window with a Vulkan
// swapchain shows the progressive image of render::Renderer (set_view/step/read_image), in
// memory or streamed through the GPU cache (--gpu-budget). The loop (viewer.cpp): input ->
// camera (controller or --play path) -> set_view on change -> step() until the view has
// converged and accumulated --spp samples, then idle (events only) -> sRGB 8-bit frame on the
// CPU + debug views + HUD -> swapchain copy and present.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"
#include "render/cell_lines.h"
#include "render/frame_pacer.h"
#include "render/renderer.h"
#include "shading/ambient_occlusion.h"
#include "store/slice.h"
#include "store/threshold.h"
#include "store/type_style.h"

namespace mds::viewer {

struct ViewerOptions {
  std::string store;        // a store (.mds) or a series index (.series; keys Left/Right/Home/End/Space)
  std::string series_frames = "all";  // --series-frames: the frames of a series the keys step through
  uint64_t gpu_budget = 0;  // 0: in memory
  render::RenderSettings render;  // width/height = initial window size; spp = samples to accumulate at rest
  std::vector<store::TypeColorSpec> type_colors;  // --type-color, resolved against the store's types
  std::vector<std::string> hide_types;            // --hide-type keys (in memory only)
  std::vector<store::TypeRadiusSpec> type_radii;  // --type-radius (in memory only)
  std::vector<store::Slice> slices;               // --slice (the keys , . / move and invert the last one)
  std::optional<store::Threshold> threshold;      // --threshold (the keys Z X, Shift+Z Shift+X, I move and invert it)
  shading::AoSettings ao;                         // --ao, --ao-radius, --ao-strength
  render::CellMode cell = render::CellMode::automatic;  // --cell, resolved against each store (render.cell_color_srgb, cell_width_px: --cell-color, --cell-width)
  render::StreamSettings stream;
  std::string camera;       // --camera spec, empty: default view `view`
  int view = 0;
  double fov_y_deg = 40.0;  // --fov
  bool ortho = false;       // --ortho
  std::string play;         // --play PATH_FILE, or a built-in path: orbit, flythrough, jumps
  uint32_t play_frames = 240;  // frames of a built-in --play path
  bool play_series = false;    // --play-series: a series plays from the start (as after Space)
  std::string record;       // --record PATH_FILE
  std::string screenshot;   // --screenshot FILE (PNG), saved when exiting
  std::string frame_log;    // --frame-log CSV: one row per displayed frame
  uint32_t exit_after_frames = 0;  // 0: run until closed
  bool hud = true;          // --no-hud: start with the HUD hidden
  bool dynamic_resolution = true;  // --fixed-resolution: off (render/frame_pacer.h)
  render::PacerSettings pacer;     // --frame-ms-target, --min-scale
  int device = -1;
};

// The key bindings, one per line ("key  action"), for --help and the docs.
const char* key_help();

// Runs the viewer until the window is closed (or --exit-after-frames, or the end of --play).
// Errors as values.
Status run_viewer(const ViewerOptions& options);

}  // namespace mds::viewer
