// `mdstream view STORE [--gpu-budget B] [options]`: the interactive viewer (src/viewer/): a
// window (GLFW + Vulkan swapchain) showing the progressive, culled rendering of a store, in
// memory or streamed through a GPU cache of --gpu-budget bytes. Keys are listed by --help.
#include <memory>
#include <string>

#include "cli/command.h"
#include "core/byte_size.h"
#include "streaming/residency.h"
#include "cli/vulkan/render_options.h"
#include "cli/vulkan/stream_options.h"
#include "viewer/viewer.h"

namespace mds::cli {
namespace {

struct ViewCliOptions {
  viewer::ViewerOptions v;
  StreamOptions stream;
  PacingOptions pacing;
  CullingOptions cull;
  AppearanceOptions look;  // --background, --type-color, --type-radius, --hide-type
  uint32_t width = 960, height = 540, spp = 16;
};

Status run_view(ViewCliOptions& o) {
  viewer::ViewerOptions v = o.v;
  if (!o.stream.gpu_budget.empty()) {
    MDS_ASSIGN_OR_RETURN(v.stream, stream_settings(o.stream));
    v.gpu_budget = v.stream.gpu_budget;
  }
  MDS_TRY(apply_culling_options(o.cull, v.render));
  MDS_ASSIGN_OR_RETURN(const Appearance look, parse_appearance_options(o.look));
  v.render.background_srgb = look.background_srgb;
  v.render.color_by = look.color_by;
  v.type_colors = look.type_colors;  // resolved when the viewer has opened the store
  v.hide_types = look.hide_types;
  v.type_radii = look.type_radii;
  v.slices = look.slices;
  v.threshold = look.threshold;
  v.ao = look.ao;
  v.cell = look.cell;
  v.render.cell_color_srgb = look.cell_color_srgb;
  v.render.cell_width_px = look.cell_width_px;
  if (o.v.fov_y_deg <= 0.0 || o.v.fov_y_deg >= 180.0)
    return make_error(Errc::invalid_argument, "--fov {}: expected degrees in (0, 180)", o.v.fov_y_deg);
  v.render.width = o.width;
  v.render.height = o.height;
  v.render.spp = o.spp;
  v.dynamic_resolution = o.pacing.dynamic;
  MDS_ASSIGN_OR_RETURN(v.pacer, pacer_settings(o.pacing));
  return viewer::run_viewer(v);
}

void setup_view(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<ViewCliOptions>();
  sub.add_option("store", opt->v.store, "Store file (.mds), or a series index (.series: Left/Right step its frames)")
      ->required();
  sub.add_option("--series-frames", opt->v.series_frames,
                 "Frames of a series to step through: all, last, K, or a slice A:B[:S] (the first is shown first; "
                 "one colour range over all of them)")
      ->capture_default_str();
  add_stream_options(sub, opt->stream, false, true);
  add_pacing_options(sub, opt->pacing, true);
  sub.add_option("--width", opt->width, "Initial window width")->check(CLI::Range(16u, 16384u))->capture_default_str();
  sub.add_option("--height", opt->height, "Initial window height")->check(CLI::Range(16u, 16384u))->capture_default_str();
  sub.add_option("--spp", opt->spp, "Samples per pixel accumulated while the camera rests")
      ->check(CLI::Range(1u, 65536u))
      ->capture_default_str();
  sub.add_option("--camera", opt->v.camera, "Start camera ex,ey,ez,tx,ty,tz[,ux,uy,uz] (data coordinates)");
  sub.add_option("--view", opt->v.view, "Default start view: 0 front, 1 oblique top, 2 close-up of a corner")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  sub.add_option("--fov", opt->v.fov_y_deg, "Vertical field of view in degrees")->capture_default_str();
  sub.add_flag("--ortho", opt->v.ortho, "Start with an orthographic projection");
  add_appearance_options(sub, opt->look);
  add_culling_options(sub, opt->cull,
                      "Start with occlusion culling off (key C toggles; keys [ ] change --cocc, K cycles --coverage)");
  sub.add_option("--play", opt->v.play,
                 "Replay the camera keyframes of this camera path file (docs/camera-path.md), or a built-in path: "
                 "orbit, flythrough, jumps");
  sub.add_option("--play-frames", opt->v.play_frames, "Frames of a built-in --play path")
      ->check(CLI::Range(1u, 10000000u))
      ->capture_default_str();
  sub.add_flag("--play-series", opt->v.play_series,
               "A series (.series) plays from the start: each frame once it has refined, looping (key Space stops)");
  sub.add_option("--record", opt->v.record, "Save the session's camera path to this file when the viewer exits");
  sub.add_option("--screenshot", opt->v.screenshot, "Save the last displayed frame as PNG when the viewer exits (after Esc a view still refining "
                 "settles first, at most 30 s: a streamed view finishes loading)");
  sub.add_option("--exit-after-frames", opt->v.exit_after_frames,
                 "Exit after this many displayed frames (default: run until closed, or until a --play path ended "
                 "and the view converged)");
  sub.add_option("--frame-log", opt->v.frame_log, "Write one CSV row per displayed frame (times, samples, cache)");
  sub.add_flag("--no-hud", [opt](int64_t) { opt->v.hud = false; }, "Start with the heads-up display hidden (key H)");
  sub.add_option("--device", opt->v.device, "Vulkan device index (default: automatic, discrete GPU first)");
  sub.footer(std::string("\nKeys:\n") + viewer::key_help() +
             "\n\nNeeds a display (X11/Wayland); headless: xvfb-run mdstream view STORE ...");
  sub.callback([opt, &exit_code] {
    Status st = run_view(*opt);
    exit_code = st.ok() ? 0 : report("view", st.error());
  });
}

Registrar reg("view", "Interactive viewer: window, camera, HUD, streaming from a GPU budget", setup_view);

}  // namespace
}  // namespace mds::cli
