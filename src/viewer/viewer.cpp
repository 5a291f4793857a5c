#include "viewer/viewer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <optional>

#include <vulkan/vulkan.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <fmt/format.h>

#include "render/camera_path.h"
#include "render/pick.h"
#include "viewer/camera_controller.h"
#include "viewer/color_keys.h"
#include "overlay/axis_tripod.h"
#include "overlay/canvas.h"
#include "viewer/debug_views.h"
#include "viewer/frame_log.h"
#include "viewer/hud.h"
#include "viewer/input.h"
#include "viewer/path_recorder.h"
#include "viewer/render_host.h"
#include "viewer/slice_keys.h"
#include "viewer/threshold_keys.h"
#include "viewer/window.h"

namespace mds::viewer {

// After Esc, how long a --screenshot waits at most for the view to settle (a streamed view on a
// slow disk, culling capped at --max-iterations: both settle well within it on lavapipe).
constexpr double kScreenshotSettleS = 30.0;

const char* key_help() {
  return "Mouse: left drag orbit, middle or shift+left drag pan, wheel zoom, right click names the particle under the "
         "cursor (a second one: their distance)\n"
         "W/S A/D Q/E  fly forward/back, left/right, down/up (held)\n"
         "R  reset the view      F/G  field of view -/+ 5 deg      O  orthographic on/off\n"
         "H  HUD on/off          1  normal view   2  occlusion classes   3  cull buffer depth   4  confidence\n"
         "B  node bounds on/off  Shift+D  density histogram of the pixel under the cursor\n"
         "C  culling on/off      [ ]  C_occ -/+ 0.01      - =  spp /2 *2      K  coverage auto/expected/exact\n"
         ", .  move the last --slice back/forward along its normal by 1/50 of the data (Shift: 1/500)   /  invert it\n"
         "Z X  the --threshold's lower bound down/up by 1/50 of the property's range (Shift: its upper bound)   "
         "I  invert it\n"
         "L  ambient occlusion on/off (--ao; radius --ao-radius)\n"
         "V  colour by: type / own colours / x / y / z / property      M  next colormap\n"
         "Left/Right  previous/next frame of a series (.series)   Home/End  first/last frame   "
         "Space  play the series (each frame once it has refined; loops)\n"
         "P  save a screenshot (mdstream-view-<time>.png)  Esc  quit";
}

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

std::string screenshot_name() {
  const std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", std::localtime(&t));
  std::string base = std::string("mdstream-view-") + buf;
  std::string name = base + ".png";
  for (int i = 2; std::filesystem::exists(name); ++i) name = base + "-" + std::to_string(i) + ".png";
  return name;
}

struct ViewState {
  bool hud = true;
  DebugView view = DebugView::normal;
  bool bounds = false;
  bool histogram = false;
};

class Viewer {
 public:
  explicit Viewer(const ViewerOptions& o) : o_(o) {}
  Status run();

 private:
  Status setup();
  Status recreate_renderer();
  // What the slice and threshold keys of one frame add up to (applied once, after the keys).
  struct FilterKeys {
    double slice_steps = 0.0;  // , .
    bool slice_invert = false;  // /
    double lower_steps = 0.0, upper_steps = 0.0;  // Z X, Shift+Z Shift+X
    bool threshold_invert = false;                // I
  };
  void handle_keys(const InputFrame& in, bool& recreate, bool& quit, FilterKeys& filter);
  // The last slice moved by `steps` key steps and inverted when `invert` (RenderHost::set_slices).
  void apply_slice_keys(double steps, bool invert);
  // The threshold's bounds moved and inverted (threshold_keys.h step_threshold; RenderHost::set_threshold).
  void apply_threshold_keys(const FilterKeys& k);
  // The HUD's threshold line for the threshold shown (empty without one).
  void update_threshold_line();
  // After the slice or threshold keys' re-load (RenderHost::set_slices / set_threshold, begun at
  // `started`) returned `st`: its time counted, the view restarted; an error becomes the message
  // (false), else the picks go (the new filter may leave them out).
  bool reload(const Status& st, Clock::time_point started);
  // The message row shows the `render` option of what the window shows, and stderr prints it.
  void say_option(const std::string& option);
  // A series: shows its picked frame at `position` (RenderHost::set_series_position).
  void show_series_position(size_t position);
  // A right click at `cursor` (framebuffer pixels): the particle the pixel under it shows
  // (render/pick.h, the ray through the pixel's centre), named in the message line and on
  // stderr with its distance from the particle picked before (OVITO's distance measurement),
  // and both marked on the image until a pick misses, a new slice or series frame.
  void pick_at(glm::dvec2 cursor);
  // The colour keys: V the next colour choice (color_keys.h next_color_by), M the next colormap;
  // printed as `render` options on stderr.
  void apply_color_key(bool colormap);
  // The HUD's legend row for the renderer's colour choice: the types, the colormap or none.
  void update_legend();
  // The HUD's message row (kept 4 s).
  void say(std::string m) {
    message_ = std::move(m);
    message_time_ = Clock::now();
  }
  Status compose(const InputFrame& in);

  const ViewerOptions& o_;
  std::unique_ptr<Window> window_;
  std::unique_ptr<vk::Context> ctx_;
  std::unique_ptr<Swapchain> swapchain_;
  std::unique_ptr<RenderHost> host_;
  std::unique_ptr<Input> input_;
  std::unique_ptr<FrameLog> log_;
  CameraController controller_;
  std::optional<render::FramePacer> pacer_;  // dynamic resolution (--fixed-resolution: none)
  double render_scale_ = 1.0;
  std::optional<render::CameraPath> play_;
  std::optional<PathRecorder> recorder_;
  ViewState vs_;
  HudState hud_;
  Canvas image_;    // the renderer's image as 8-bit sRGB
  Canvas display_;  // image_ + debug views + HUD: what is presented (and saved)
  render::Camera view_camera_;  // camera handed to set_view (near/far fitted)
  bool have_view_ = false;
  bool idle_ = false;
  // Series keys of this frame: a step (Left/Right) or a position (Home/End); Space plays.
  int64_t series_step_ = 0;
  std::optional<size_t> series_goto_;
  bool series_playing_ = false;
  double reload_ms_ = 0.0;  // this frame's store or slice loads (frame log: reload_ms)
  // After a series step while streaming, the frame before stays on screen until the new store's
  // view is complete (every wanted node resident): a playing series shows whole frames, not the
  // background and then the first waves of nodes. Moving the camera ends it.
  bool hold_image_ = false;
  std::optional<Error> render_error_;
  std::string message_;
  Clock::time_point message_time_;
  std::optional<render::PickedParticle> picked_, picked_before_;
  std::string pick_line_;  // what pick_at said of picked_ (the HUD keeps it while it is marked)
};

Status Viewer::setup() {
  if (o_.render.width == 0 || o_.render.height == 0)
    return make_error(Errc::invalid_argument, "--width/--height must be positive");
  if (o_.play_series && !store::is_series_path(o_.store))
    return make_error(Errc::invalid_argument, "--play-series: {} is not a series (a .series index)", o_.store);
  // A --play file is read before the window opens (errors early); built-in names after the
  // bounds are known.
  const bool builtin_play = !o_.play.empty() && !std::filesystem::exists(o_.play) &&
                            render::parse_builtin_path(o_.play).ok();
  if (!o_.play.empty() && !builtin_play) {
    MDS_ASSIGN_OR_RETURN(render::CameraPath path, render::CameraPath::load(o_.play));
    if (path.empty()) return make_error(Errc::invalid_argument, "--play {}: no keyframes", o_.play);
    play_ = std::move(path);
  }
  if (!o_.record.empty()) recorder_.emplace();
  if (!o_.frame_log.empty()) {
    MDS_ASSIGN_OR_RETURN(log_, FrameLog::open(o_.frame_log));
  }
  const std::string title = "mdstream view - " + std::filesystem::path(o_.store).filename().string();
  MDS_ASSIGN_OR_RETURN(window_, Window::create(o_.render.width, o_.render.height, title));
  vk::ContextOptions copt = vk::ContextOptions::from_env();
  copt.device_index = o_.device;
  window_->add_to_context_options(copt);
  MDS_ASSIGN_OR_RETURN(ctx_, vk::Context::create(copt));
  uint32_t fw = 0, fh = 0;
  window_->framebuffer_size(fw, fh);
  if (fw == 0 || fh == 0) fw = o_.render.width, fh = o_.render.height;
  MDS_ASSIGN_OR_RETURN(swapchain_, Swapchain::create(*ctx_, fw, fh));
  MDS_ASSIGN_OR_RETURN(host_, RenderHost::open(*ctx_, o_));
  input_ = std::make_unique<Input>(window_->handle());
  vs_.hud = o_.hud;
  if (o_.dynamic_resolution) {
    render::PacerSettings ps = o_.pacer;
    ps.cpu_device = ctx_->info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
    pacer_.emplace(ps);
  }
  MDS_TRY(host_->recreate(fw, fh));

  // Home camera: --camera or a default view, with --fov/--ortho.
  render::Camera home;
  const double aspect = double(fw) / double(std::max(fh, 1u));
  if (!o_.camera.empty()) {
    MDS_ASSIGN_OR_RETURN(home, render::parse_camera(o_.camera));
  } else {
    MDS_ASSIGN_OR_RETURN(home, render::default_view(o_.view, host_->view_bounds(), o_.fov_y_deg, aspect));
  }
  home.fov_y_deg = o_.fov_y_deg;
  home.ortho = o_.ortho;
  controller_ = CameraController(home, host_->view_bounds());
  if (builtin_play) {
    MDS_ASSIGN_OR_RETURN(render::BuiltinPath kind, render::parse_builtin_path(o_.play));
    play_ = render::builtin_path(kind, host_->view_bounds(), std::max(o_.play_frames, 1u), o_.fov_y_deg, aspect);
  }

  series_playing_ = o_.play_series;
  hud_.store_name = host_->is_series() ? host_->series_entry()->name
                                       : std::filesystem::path(o_.store).filename().string();
  hud_.streaming = host_->streaming();
  hud_.meshlets = host_->meshlets();
  update_threshold_line();
  update_legend();
  return {};
}

void Viewer::update_legend() {
  const render::ColorBy& color_by = host_->settings().color_by;
  if (!color_by.by_type() && host_->renderer())
    hud_.legend = overlay::colormap_legend(color_by.by_property() ? std::string(host_->reader().header().property_name)
                                                                  : render::color_axis_name(color_by.axis),
                                           host_->renderer()->color_range(), color_by.map);
  else if (color_by.by_color())
    hud_.legend = {};  // the particles' own colours: no legend explains them
  else
    hud_.legend = overlay::type_legend(host_->reader().types(), host_->settings().type_colors_srgb, host_->shown_types());
}

void Viewer::apply_color_key(bool colormap) {
  render::ColorBy c = host_->settings().color_by;
  const store::FileHeader& h = host_->reader().header();
  if (colormap) {
    if (c.by_type()) {
      say("no colormap: colour by x, y, z or the property first (V)");
      return;
    }
    c.map = next_colormap(c.map);
  } else {
    c = next_color_by(c, host_->has_colors(), host_->has_property());  // a series: what every frame has
  }
  bool remade = false;
  const Status st = host_->set_color_by(c, &remade);
  if (remade) {  // a new renderer (and cache): it needs the view
    have_view_ = false;
    render_error_.reset();
  }
  if (!st.ok()) {
    say(st.error().message);
    return;
  }
  idle_ = false;
  update_legend();
  const std::string options = color_options(host_->settings().color_by, h.property_name);
  std::fprintf(stderr, "mdstream view: %s\n", options.c_str());
  say(options);
}

Status Viewer::recreate_renderer() {
  render_error_.reset();
  Status st = host_->recreate(host_->settings().width, host_->settings().height);
  have_view_ = false;
  idle_ = false;
  return st;
}

void Viewer::handle_keys(const InputFrame& in, bool& recreate, bool& quit, FilterKeys& filter) {
  auto& rs = host_->settings();
  for (size_t i = 0; i < in.keys_pressed.size(); ++i) {
    const int key = in.keys_pressed[i];
    const bool shift = in.key_mods[i] & GLFW_MOD_SHIFT;
    switch (key) {
      case GLFW_KEY_ESCAPE: quit = true; break;
      case GLFW_KEY_R: controller_.reset(); break;
      case GLFW_KEY_F: controller_.change_fov(-5.0); break;
      case GLFW_KEY_G: controller_.change_fov(+5.0); break;
      case GLFW_KEY_O: controller_.toggle_ortho(); break;
      case GLFW_KEY_H: vs_.hud = !vs_.hud; break;
      case GLFW_KEY_1: vs_.view = DebugView::normal; break;
      case GLFW_KEY_2: vs_.view = DebugView::classes; break;
      case GLFW_KEY_3: vs_.view = DebugView::cull_depth; break;
      case GLFW_KEY_4: vs_.view = DebugView::confidence; break;
      case GLFW_KEY_B: vs_.bounds = !vs_.bounds; break;
      case GLFW_KEY_D:
        if (shift) vs_.histogram = !vs_.histogram;
        break;
      case GLFW_KEY_C:
        rs.cull = !rs.cull;
        recreate = true;
        say(rs.cull ? "culling on" : "culling off");
        break;
      case GLFW_KEY_LEFT_BRACKET:
      case GLFW_KEY_RIGHT_BRACKET: {
        const double c = std::clamp(rs.cull_settings.c_occ + (key == GLFW_KEY_LEFT_BRACKET ? -0.01 : 0.01), 0.5, 0.999);
        rs.cull_settings.c_occ = c;  // kept for a later re-creation (key C)
        Status st = host_->renderer() ? host_->renderer()->set_c_occ(c) : Status{};
        say(st.ok() ? fmt::format("C_occ {:.3f}", c) : st.error().message);
        break;
      }
      case GLFW_KEY_K: {  // sample-area model: auto -> expected -> exact -> auto
        using render::culling::Coverage;
        auto& cov = rs.cull_settings.coverage;
        cov = cov == Coverage::automatic ? Coverage::expected
              : cov == Coverage::expected ? Coverage::exact
                                          : Coverage::automatic;  // kept for a later re-creation (key C)
        Status st = host_->renderer() ? host_->renderer()->set_coverage(cov) : Status{};
        say(st.ok() ? "coverage " + render::culling::coverage_name(cov) : st.error().message);
        break;
      }
      case GLFW_KEY_MINUS:
      case GLFW_KEY_EQUAL: {
        const uint32_t spp = key == GLFW_KEY_MINUS ? std::max(rs.spp / 2, 1u) : std::min(rs.spp * 2, 65536u);
        rs.spp = spp;
        Status st = host_->renderer() ? host_->renderer()->set_spp(spp) : Status{};
        say(st.ok() ? fmt::format("spp {}", spp) : st.error().message);
        break;
      }
      case GLFW_KEY_COMMA:
      case GLFW_KEY_PERIOD:
        filter.slice_steps += (shift ? 0.1 : 1.0) * (key == GLFW_KEY_PERIOD ? 1.0 : -1.0);
        break;
      case GLFW_KEY_SLASH: filter.slice_invert = !filter.slice_invert; break;
      case GLFW_KEY_Z:
      case GLFW_KEY_X:
        (shift ? filter.upper_steps : filter.lower_steps) += key == GLFW_KEY_X ? 1.0 : -1.0;
        break;
      case GLFW_KEY_I: filter.threshold_invert = !filter.threshold_invert; break;
      case GLFW_KEY_V: apply_color_key(false); break;
      case GLFW_KEY_U: {  // the simulation cell on/off (--cell; render/cell_lines.h)
        const bool on = !host_->cell_shown();
        Status st = host_->set_cell_shown(on);
        idle_ = false;
        if (st.ok()) std::fprintf(stderr, "mdstream view: --cell %s\n", on ? "on" : "off");
        say(!st.ok() ? st.error().message : on ? std::string("simulation cell on") : std::string("simulation cell off"));
        break;
      }
      case GLFW_KEY_M: apply_color_key(true); break;
      case GLFW_KEY_LEFT:
      case GLFW_KEY_RIGHT:
      case GLFW_KEY_HOME:
      case GLFW_KEY_END:
      case GLFW_KEY_SPACE:
        if (!host_->is_series()) {
          say("no series: open a .series index (convert -o RUN.mds.series)");
        } else if (key == GLFW_KEY_SPACE) {
          series_playing_ = !series_playing_;
        } else if (key == GLFW_KEY_HOME || key == GLFW_KEY_END) {
          series_goto_ = key == GLFW_KEY_HOME ? 0 : host_->series_positions() - 1;
          series_step_ = 0;
        } else {
          series_step_ += key == GLFW_KEY_RIGHT ? 1 : -1;
        }
        break;
      case GLFW_KEY_L: {  // ambient occlusion on/off (RenderSettings::ao_*), kept for a re-creation (key C)
        const bool on = !(rs.ao_strength > 0.0 && rs.ao_radius > 0.0);
        rs.ao_radius = on ? host_->ao_radius() : 0.0;
        rs.ao_strength = on ? host_->ao_strength() : 0.0;
        Status st = host_->renderer() ? host_->renderer()->set_ambient_occlusion(rs.ao_radius, rs.ao_strength) : Status{};
        idle_ = false;
        const bool applied = host_->renderer() && host_->renderer()->stats().ambient_occlusion;
        say(!st.ok() ? st.error().message
            : !on    ? std::string("ambient occlusion off")
            : applied ? fmt::format("ambient occlusion on (radius {:g}, strength {:g})", rs.ao_radius, rs.ao_strength)
                      : std::string("ambient occlusion: needs the visibility route (64-bit atomics)"));
        break;
      }
      case GLFW_KEY_P: {
        const std::string name = screenshot_name();
        Status st = overlay::write_canvas_png(name, display_);
        say(st.ok() ? "saved " + name : st.error().message);
        break;
      }
      default: break;
    }
  }
  if (!message_.empty() && ms_since(message_time_) > 4000) message_.clear();
}

void Viewer::update_threshold_line() {
  const auto& t = host_->threshold();  // the particles kept by their property (store/threshold.h)
  hud_.threshold =
      t ? fmt::format("threshold {} {}", host_->reader().header().property_name, store::threshold_spec(*t)) : "";
}

void Viewer::apply_threshold_keys(const FilterKeys& k) {
  message_time_ = Clock::now();
  const store::FileHeader& h = host_->reader().header();
  if (!(h.flags & store::kFlagProperty)) {
    message_ = "no property to threshold: convert with --property NAME";
    return;
  }
  const store::Threshold t = step_threshold(host_->threshold(), k.lower_steps, k.upper_steps, k.threshold_invert,
                                            double(h.property_min), double(h.property_max));
  render_error_.reset();
  const auto t0 = Clock::now();
  if (!reload(host_->set_threshold(t), t0)) return;  // in memory: the scene again; streaming: a new cache
  update_threshold_line();
  say_option(threshold_option(t));  // for `render` with the same threshold
}

bool Viewer::reload(const Status& st, Clock::time_point started) {
  reload_ms_ += ms_since(started);
  have_view_ = false;
  idle_ = false;
  if (!st.ok()) {
    message_ = st.error().message;
    return false;
  }
  picked_.reset();  // the new filter may have left it out
  picked_before_.reset();
  return true;
}

void Viewer::say_option(const std::string& option) {
  message_ = option;
  fmt::print(stderr, "mdstream view: {}\n", message_);
}

void Viewer::apply_slice_keys(double steps, bool invert) {
  message_time_ = Clock::now();
  if (host_->slices().empty()) {
    message_ = "no slice to move: start with --slice NX,NY,NZ,D[,WIDTH]";
    return;
  }
  std::vector<store::Slice> slices = host_->slices();
  const store::FileHeader& h = host_->reader().header();
  slices.back() = step_slice(slices.back(), steps, invert, h.bounds_min, h.bounds_max);
  render_error_.reset();
  const auto t0 = Clock::now();
  if (!reload(host_->set_slices(slices), t0)) return;  // in memory: the scene again; streaming: a new cache
  say_option(slice_options(host_->slices()));  // for `render` with the same cut
}

void Viewer::pick_at(glm::dvec2 cursor) {
  message_time_ = Clock::now();
  const std::optional<render::PickedParticle> before = picked_;
  picked_.reset();
  picked_before_.reset();
  const uint32_t w = host_->settings().width, h = host_->settings().height;
  if (w == 0 || h == 0) return;
  const glm::uvec2 px(uint32_t(std::clamp(std::floor(cursor.x), 0.0, double(w - 1))),
                      uint32_t(std::clamp(std::floor(cursor.y), 0.0, double(h - 1))));
  render::Camera cam = have_view_ ? view_camera_ : controller_.camera();
  render::fit_clip_planes(cam, host_->renderer() ? host_->renderer()->clip_bounds() : host_->bounds());
  auto p = render::pick_particle(host_->reader(), cam, w, h, glm::dvec2(px) + 0.5, host_->scene_options());
  if (!p.ok()) {
    message_ = "pick: " + p.error().message;
  } else if (!*p) {
    message_ = fmt::format("pick {},{}: no particle", px.x, px.y);
  } else {
    picked_ = **p;
    message_ = fmt::format("pick {},{}: {}", px.x, px.y, render::describe_pick(host_->reader(), *picked_));
    if (before && (before->node != picked_->node || before->index_in_node != picked_->index_in_node)) {
      picked_before_ = before;
      message_ += fmt::format("; {:.6g} from node {} particle {}", glm::length(picked_->position - before->position),
                              before->node, before->index_in_node);
    }
  }
  pick_line_ = picked_ ? message_ : std::string();
  // On stderr too: `render --pick X,Y` at this window size and camera answers the same.
  fmt::print(stderr, "mdstream view: {}\n", message_);
}

void Viewer::show_series_position(size_t position) {
  render_error_.reset();
  const auto t0 = Clock::now();
  const Status st = host_->set_series_position(position);  // the store of that frame; camera and slices stay
  reload_ms_ += ms_since(t0);
  have_view_ = false;
  idle_ = false;
  message_time_ = Clock::now();
  if (!st.ok()) {
    message_ = st.error().message;
    series_playing_ = false;
    return;
  }
  hud_.store_name = host_->series_entry()->name;
  picked_.reset();  // it named a particle of the frame before's store
  picked_before_.reset();
  hud_.meshlets = host_->meshlets();
  update_legend();  // the frame's store may have other types (or colours)
  hold_image_ = host_->streaming() && image_.width() > 0;
  // On stderr too, for `render --series-frames` of the same frame.
  message_ = fmt::format("--series-frames {}", host_->series_frame());
  fmt::print(stderr, "mdstream view: {} ({}, time {:g})\n", message_, host_->series_entry()->name,
             host_->series_entry()->time);
}

// Debug views that read the culling loop's per-pixel state are drawn at the render size; the
// result is upscaled to the window (dynamic resolution), then bounds and the HUD are drawn.
Status Viewer::compose(const InputFrame& in) {
  display_ = image_;
  const uint32_t win_w = host_->settings().width, win_h = host_->settings().height;
  render::Camera cam = view_camera_;
  render::fit_clip_planes(cam, host_->renderer() ? host_->renderer()->clip_bounds() : host_->bounds());
  render::culling::CullLoop* loop = host_->renderer() ? host_->renderer()->cull_loop() : nullptr;
  auto note = [&](const std::string& m) {
    if (hud_.message.empty()) hud_.message = m;
  };
  if (vs_.view != DebugView::normal && render_error_) {
    // nothing to inspect
  } else if (vs_.view != DebugView::normal && !loop) {
    note(fmt::format("{}: culling is off (C)", debug_view_name(vs_.view)));
  } else if (vs_.view == DebugView::classes) {
    if (!host_->scene()) {
      // Streaming: the pool's slots change owners, so show the node classes, which the loop
      // keeps for every node, resident or not (the classes that drive the cache).
      draw_class_boxes(display_, cam, host_->node_boxes(), loop->node_classes());
      note("classes: nodes (streaming)");
    } else {
      MDS_ASSIGN_OR_RETURN(std::vector<uint32_t> classes, loop->read_meshlet_classes());
      draw_meshlet_classes(display_, cam, *host_->scene(), classes);
    }
  } else if (vs_.view == DebugView::cull_depth || vs_.view == DebugView::confidence) {
    MDS_ASSIGN_OR_RETURN(std::vector<glm::vec4> ps, loop->read_pixel_state());
    if (vs_.view == DebugView::cull_depth) {
      draw_cull_depth(display_, ps, cam.near, cam.far);
    } else {
      draw_confidence(display_, ps, host_->settings().cull_settings.c_occ);
    }
  }
  if (vs_.histogram) {
    if (!loop) {
      note("histogram: culling is off (C)");
    } else {
      MDS_ASSIGN_OR_RETURN(std::vector<float> hist, loop->read_histograms());
      MDS_ASSIGN_OR_RETURN(std::vector<glm::vec2> ranges, loop->read_hist_ranges());
      const double sx = double(display_.width()) / double(std::max(win_w, 1u));
      const double sy = double(display_.height()) / double(std::max(win_h, 1u));
      const uint32_t x = uint32_t(std::clamp(in.cursor.x * sx, 0.0, double(display_.width() - 1)));
      const uint32_t y = uint32_t(std::clamp(in.cursor.y * sy, 0.0, double(display_.height() - 1)));
      draw_histogram(display_, hist, ranges, loop->bins(), x, y);
    }
  }
  if (display_.width() != win_w || display_.height() != win_h) display_ = display_.resized_nearest(win_w, win_h);
  if (vs_.bounds) {
    const Projector proj(cam, display_.width(), display_.height());
    const auto& boxes = host_->node_boxes();
    // Streaming: the nodes resident in the device pool now; in memory: every node.
    const std::vector<uint8_t> resident =
        host_->renderer() ? host_->renderer()->resident_nodes() : std::vector<uint8_t>{};
    std::vector<uint32_t> show;
    for (uint32_t i = 0; i < boxes.size(); ++i)
      if (!host_->streaming() || (i < resident.size() && resident[i])) show.push_back(i);
    const size_t stride = std::max<size_t>(1, show.size() / 20000);  // at most ~20k boxes per frame
    for (size_t k = 0; k < show.size(); k += stride)
      draw_box(display_, proj, cam, boxes[show[k]], {80, 200, 255, 160});
    if (host_->streaming()) note(fmt::format("bounds: the {} resident nodes of {}", show.size(), boxes.size()));
  }
  if (picked_ && vs_.hud) {
    // A cross around each picked particle's centre, its arms outside the sphere; the particle
    // picked before dimmer, and a line between the two.
    const Projector proj(cam, display_.width(), display_.height());
    const glm::dvec3 side = glm::normalize(glm::cross(cam.target - cam.eye, cam.up));
    auto mark = [&](const render::PickedParticle& q, Rgba8 color) -> std::optional<glm::dvec2> {
      glm::dvec3 c, edge;
      if (!proj.project(q.position, c) || !proj.project(q.position + q.radius * side, edge)) return std::nullopt;
      const double gap = std::max(glm::length(glm::dvec2(edge) - glm::dvec2(c)), 3.0), arm = gap + 8.0;
      const glm::dvec2 m(c);
      for (const glm::dvec2 dir : {glm::dvec2(1, 0), glm::dvec2(-1, 0), glm::dvec2(0, 1), glm::dvec2(0, -1)})
        display_.line(m + gap * dir, m + arm * dir, color);
      return m;
    };
    const auto a = mark(*picked_, {255, 0, 255, 255});
    const auto b = picked_before_ ? mark(*picked_before_, {255, 140, 255, 255}) : std::nullopt;
    if (a && b) display_.line(*a, *b, {255, 0, 255, 110});
  }
  if (vs_.hud) {
    draw_hud(display_, hud_);
    overlay::draw_tripod(display_, cam, overlay::LegendCorner::bottom_left);  // OVITO's viewport tripod
  }
  return {};
}

Status Viewer::run() {
  MDS_TRY(setup());
  const auto start = Clock::now();
  uint32_t frame = 0;
  render::FrameReport report;
  uint64_t last_bytes_read = 0;
  auto last_rate_time = Clock::now();
  double read_rate = 0.0;
  auto last_iter = Clock::now();
  bool quit = false;
  std::optional<Clock::time_point> quit_at;  // when Esc came, while a --screenshot view settles
  for (;;) {
    const auto t0 = Clock::now();
    reload_ms_ = 0.0;
    const double dt = std::min(std::chrono::duration<double>(t0 - last_iter).count(), 0.25);
    last_iter = t0;
    const bool playing = play_ && frame < play_->frame_count() && !quit_at;  // Esc holds the camera shown
    if (idle_ && !playing) glfwWaitEventsTimeout(0.1);
    else glfwPollEvents();
    InputFrame in = input_->poll();
    if (window_->should_close()) break;

    bool recreate = false;
    FilterKeys filter;
    // Esc: this frame is still shown (and recorded), then the loop ends.
    handle_keys(in, recreate, quit, filter);
    for (const glm::dvec2& c : in.picks) pick_at(c);

    // Camera: the path while playing, else the controller.
    if (playing) {
      controller_.set(play_->at(frame));
    } else {
      if (in.orbit_delta != glm::dvec2(0.0)) controller_.orbit(in.orbit_delta.x, in.orbit_delta.y, swapchain_->height());
      if (in.pan_delta != glm::dvec2(0.0)) controller_.pan(in.pan_delta.x, in.pan_delta.y, swapchain_->height());
      if (in.wheel != 0.0) controller_.zoom(in.wheel);
      if (in.fly != glm::dvec3(0.0) && !(glfwGetKey(window_->handle(), GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS))
        controller_.fly(in.fly, dt);
    }

    // Window resize: the swapchain is re-created; the renderer only resizes (below, with the
    // dynamic resolution), so its streaming cache and resident nodes survive.
    if (in.resized) {
      uint32_t fw = 0, fh = 0;
      window_->framebuffer_size(fw, fh);
      if (fw > 0 && fh > 0 && (fw != host_->settings().width || fh != host_->settings().height)) {
        MDS_TRY(swapchain_->resize(fw, fh));
        host_->settings().width = fw;
        host_->settings().height = fh;
        idle_ = false;
      }
    }
    if (recreate) {
      Status st = recreate_renderer();
      if (!st.ok()) return st;
    }
    if (filter.slice_steps != 0.0 || filter.slice_invert) apply_slice_keys(filter.slice_steps, filter.slice_invert);
    if (filter.lower_steps != 0.0 || filter.upper_steps != 0.0 || filter.threshold_invert) apply_threshold_keys(filter);
    if (series_goto_ || series_step_ != 0) {
      const int64_t n = int64_t(host_->series_positions());
      const int64_t p = series_goto_ ? int64_t(*series_goto_)
                                     : std::clamp<int64_t>(int64_t(host_->series_position()) + series_step_, 0, n - 1);
      series_goto_.reset();
      series_step_ = 0;
      if (size_t(p) != host_->series_position()) show_series_position(size_t(p));
    }

    const render::Camera& cam = controller_.camera();
    const bool moved = !have_view_ || !same_camera(cam, view_camera_);
    if (have_view_ && moved) hold_image_ = false;  // the held image shows another camera
    render::Renderer* r = host_->renderer();
    double step_ms = 0.0;
    double gpu_ms = 0.0;  // this frame's GPU passes (0: not timed)
    bool stepped = false;
    // Render size: the window's, scaled down by the pacer while the camera moves; at rest the
    // full size returns and the view refines (culling convergence, super-sampling) there.
    if (r && !render_error_ && (moved || !idle_)) {
      render_scale_ = pacer_ ? pacer_->next_scale(moved) : 1.0;
      uint32_t sw = 0, sh = 0;
      render::FramePacer::scaled_size(host_->settings().width, host_->settings().height, render_scale_, sw, sh);
      Status st = r->resize(sw, sh);
      if (!st.ok()) render_error_ = st.error();
      // One occlusion sampling pass per iteration while moving, over the scale's share of the budget.
      r->set_motion(moved, pacer_ ? pacer_->sample_share(host_->settings().width, host_->settings().height) : 1.0);
    }
    if (moved) {
      view_camera_ = cam;
      have_view_ = true;
      idle_ = false;
      if (!render_error_) {
        // A playing path tells the cache where the camera goes next (Renderer::set_path_next);
        // under the user's hand the cache learns the motion from the views.
        std::vector<render::Camera> next;
        if (playing)
          for (uint32_t k = 1; k <= render::Renderer::kPathNextViews; ++k)
            next.push_back(play_->at(std::min<uint32_t>(frame + k, play_->frame_count() - 1)));
        r->set_path_next(next);
        Status st = r->set_view(cam);
        if (!st.ok()) render_error_ = st.error();
      }
    }
    if (!idle_ && !render_error_) {
      const auto ts = Clock::now();
      auto rep = r->step();
      if (!rep.ok()) {
        render_error_ = rep.error();
      } else {
        report = std::move(*rep);
        auto img = r->read_image();
        if (!img.ok()) render_error_ = img.error();
        else if (!hold_image_ || report.complete) {
          image_.set_from_linear(*img);
          hold_image_ = false;
        }
        // read_image() waited for the frame: collect its GPU timestamps (the pacer's split).
        if (Status st = r->finish(); !st.ok()) render_error_ = st.error();
        gpu_ms = r->last_frame_gpu().ms;
        stepped = true;
        // Never idle on a moving frame: it may have rendered at a reduced scale (dynamic
        // resolution), and with few --spp it already has its samples; the next frame, at rest,
        // renders at full size.
        idle_ = !moved && report.settled && report.samples >= host_->settings().spp;
      }
      step_ms = ms_since(ts);
    }
    // Playing a series: the next frame once this one has refined (the last one loops).
    if (series_playing_ && !quit && idle_ && !render_error_ && host_->series_positions() > 1) {
      show_series_position((host_->series_position() + 1) % host_->series_positions());
      r = host_->renderer();  // a new renderer for the new store
    }
    // ... whose store is read and loaded meanwhile, beside the rendering (RenderHost::preload).
    if (series_playing_ && !render_error_ && host_->series_positions() > 1)
      host_->preload((host_->series_position() + 1) % host_->series_positions());
    if (render_error_) {
      idle_ = true;
      if (image_.width() != host_->settings().width || image_.height() != host_->settings().height)
        image_ = Canvas(host_->settings().width, host_->settings().height, {60, 30, 30, 255});
    }

    // HUD state.
    const render::CacheStats cache = r ? r->stats().cache : render::CacheStats{};
    const double since_rate = std::chrono::duration<double>(Clock::now() - last_rate_time).count();
    if (since_rate >= 0.5) {
      read_rate = double(cache.bytes_read - std::min(cache.bytes_read, last_bytes_read)) / since_rate / 1e6;
      last_bytes_read = cache.bytes_read;
      last_rate_time = Clock::now();
    }
    const auto& rs = host_->settings();
    hud_.cull = rs.cull;
    hud_.c_occ = rs.cull_settings.c_occ;
    hud_.coverage = render::culling::coverage_name(rs.cull_settings.coverage);
    hud_.spp = rs.spp;
    hud_.ortho = cam.ortho;
    hud_.fov_y_deg = cam.fov_y_deg;
    hud_.step_ms = stepped ? step_ms : 0.0;
    hud_.idle = idle_ && !render_error_;
    hud_.playing = playing || series_playing_;
    if (host_->is_series())
      hud_.series = fmt::format("series frame {} ({}/{})  time {:g}{}", host_->series_frame(),
                                host_->series_position() + 1, host_->series_positions(), host_->series_entry()->time,
                                hold_image_ ? "  loading (the frame before shown)" : "");
    hud_.recording = recorder_.has_value();
    hud_.read_mb_s = read_rate;
    hud_.view_name = debug_view_name(vs_.view);
    hud_.ao_radius = rs.ao_strength > 0.0 ? rs.ao_radius : 0.0;
    hud_.report = report;
    hud_.cache = cache;
    hud_.message = render_error_ ? "render error: " + render_error_->message : message_;
    hud_.pick = picked_ ? pick_line_ : std::string();
    hud_.dynamic_resolution = pacer_.has_value();
    hud_.render_scale = render_scale_;
    hud_.render_width = r ? r->width() : 0;
    hud_.render_height = r ? r->height() : 0;
    hud_.frame_ms_target = pacer_ ? pacer_->target_ms() : 0.0;

    MDS_TRY(compose(in));
    MDS_ASSIGN_OR_RETURN(bool presented, swapchain_->present(display_));
    if (!presented) {
      uint32_t fw = 0, fh = 0;
      window_->framebuffer_size(fw, fh);
      MDS_TRY(swapchain_->resize(fw, fh));
    }
    if (recorder_) recorder_->observe(frame, cam);
    const double frame_ms = ms_since(t0);
    hud_.frame_ms = frame_ms;
    if (pacer_ && stepped) pacer_->observe(frame_ms, report.load(), gpu_ms);
    if (log_) {
      FrameLogRow row;
      row.frame = frame;
      row.t_ms = ms_since(start);
      row.frame_ms = frame_ms;
      row.step_ms = step_ms;
      row.stepped = stepped;
      row.camera_moved = moved;
      row.report = report;
      row.cache = cache;
      row.scale = render_scale_;
      row.render_width = r ? r->width() : 0;
      row.render_height = r ? r->height() : 0;
      row.series_frame = host_->is_series() ? host_->series_frame() : -1;
      row.reload_ms = reload_ms_;
      row.held = hold_image_;
      log_->add(row);
    }
    ++frame;
    if (quit) {
      // --screenshot: a view still refining (a streamed view loading, culling, samples to come)
      // goes on until it settles, so that the file shows the settled image, not the frame the
      // key arrived in (held while loading); at most kScreenshotSettleS after Esc.
      if (o_.screenshot.empty() || idle_ || render_error_) break;
      if (!quit_at) quit_at = Clock::now();
      series_playing_ = false;  // the frame shown is the one saved
      if (std::chrono::duration<double>(Clock::now() - *quit_at).count() > kScreenshotSettleS) break;
    }
    if (o_.exit_after_frames > 0 && frame >= o_.exit_after_frames) break;
    if (o_.exit_after_frames == 0 && play_ && frame >= play_->frame_count() && idle_) break;
  }

  // Outputs (each written atomically).
  if (render_error_) return *render_error_;
  if (!o_.screenshot.empty()) MDS_TRY(overlay::write_canvas_png(o_.screenshot, display_));
  if (recorder_) {
    if (recorder_->key_count() == 0) return make_error(Errc::internal, "--record {}: no frame was shown", o_.record);
    MDS_TRY(recorder_->path().save(o_.record));
  }
  if (log_) MDS_TRY(log_->commit());
  return {};
}

}  // namespace

Status run_viewer(const ViewerOptions& options) {
  Viewer v(options);
  return v.run();
}

}  // namespace mds::viewer
