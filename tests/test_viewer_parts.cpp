// The viewer's parts without a window (src/viewer/): the camera controller, the path recorder,
// the 8-bit canvas and its text, the HUD's rows and legends, the debug views' boxes, and the
// arithmetic of the slice and colour keys. tests/test_viewer.cpp runs the viewer itself in a
// window on an Xvfb X server.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "culling/culling_constants.h"
#include "overlay/canvas.h"
#include "overlay/color_legend.h"
#include "render/camera.h"
#include "render/camera_path.h"
#include "render/scene.h"
#include "store/slice.h"
#include "viewer/camera_controller.h"
#include "viewer/color_keys.h"
#include "viewer/debug_views.h"
#include "viewer/hud.h"
#include "viewer/path_recorder.h"
#include "viewer/slice_keys.h"
#include "viewer/threshold_keys.h"

namespace fs = std::filesystem;
using namespace mds;

namespace {

render::Bounds unit_bounds() {
  render::Bounds b;
  b.min = glm::dvec3(0.0);
  b.max = glm::dvec3(10.0);
  b.radius_max = 0.5;
  return b;
}

render::Camera home_camera() {
  render::Camera c;
  c.eye = {5, 5, 40};
  c.target = {5, 5, 5};
  c.up = {0, 1, 0};
  c.fov_y_deg = 40;
  return c;
}

TEST(ViewerCamera, OrbitKeepsTargetAndDistance) {
  viewer::CameraController cc(home_camera(), unit_bounds());
  const double d0 = cc.distance();
  cc.orbit(50, 0, 100);  // a quarter of the height: 90 degrees of yaw
  EXPECT_EQ(cc.camera().target, home_camera().target);
  EXPECT_NEAR(cc.distance(), d0, 1e-9);
  EXPECT_NEAR(cc.camera().eye.y, 5.0, 1e-9);  // pure yaw about up
  EXPECT_NEAR(std::abs(cc.camera().eye.x - 5.0), d0, 1e-9);
  cc.orbit(0, 1e6, 100);  // pitch is clamped short of the pole
  const glm::dvec3 f = cc.forward();
  EXPECT_LT(std::abs(glm::dot(f, glm::dvec3(0, 1, 0))), std::cos(glm::radians(0.5)));
  EXPECT_NEAR(cc.distance(), d0, 1e-9);
  cc.reset();
  EXPECT_TRUE(viewer::same_camera(cc.camera(), home_camera()));
}

TEST(ViewerCamera, PanZoomFlyFovOrtho) {
  viewer::CameraController cc(home_camera(), unit_bounds());
  const double d0 = cc.distance();
  cc.pan(10, 0, 100);  // drag right: the scene follows the cursor, the camera moves left
  EXPECT_LT(cc.camera().eye.x, 5.0);
  EXPECT_NEAR(cc.camera().eye.x - cc.camera().target.x, 0.0, 1e-12);
  EXPECT_NEAR(cc.distance(), d0, 1e-9);
  // The point at the target depth moves by exactly the dragged pixels: 10 px of 100 = 1/10 of 2 h.
  EXPECT_NEAR(5.0 - cc.camera().target.x, 0.2 * d0 * std::tan(glm::radians(20.0)), 1e-9);
  cc.zoom(2);
  EXPECT_NEAR(cc.distance(), d0 * 0.85 * 0.85, 1e-9);
  const glm::dvec3 e0 = cc.camera().eye, t0 = cc.camera().target;
  cc.fly({0, 0, 1}, 1.0);  // forward for a second: half the bounding radius
  EXPECT_NEAR(glm::length(cc.camera().eye - e0), 0.5 * unit_bounds().bounding_radius(), 1e-9);
  EXPECT_NEAR(glm::length(cc.camera().target - t0), 0.5 * unit_bounds().bounding_radius(), 1e-9);
  EXPECT_LT(cc.camera().eye.z, e0.z);
  cc.change_fov(-100);
  EXPECT_EQ(cc.camera().fov_y_deg, 5.0);
  cc.toggle_ortho();
  EXPECT_TRUE(cc.camera().ortho);
  const double d1 = cc.distance();
  cc.zoom(1);  // ortho: the distance (and with it the half height) shrinks
  EXPECT_NEAR(cc.distance(), 0.85 * d1, 1e-9);
  EXPECT_EQ(cc.camera().ortho_half_height, 0.0);
}

TEST(ViewerRecorder, KeysChangesAndHolds) {
  viewer::PathRecorder rec;
  render::Camera a = home_camera(), b = home_camera();
  b.eye.x += 3;
  for (uint32_t f = 0; f < 5; ++f) rec.observe(f, a);  // rest
  rec.observe(5, b);                                   // move
  rec.observe(6, b);
  const auto path = rec.path();
  ASSERT_EQ(path.keys().size(), 3u);
  EXPECT_EQ(path.keys()[0].frame, 0u);
  EXPECT_EQ(path.keys()[1].frame, 4u);  // the rest is keyed before the move
  EXPECT_EQ(path.keys()[2].frame, 5u);
  EXPECT_TRUE(viewer::same_camera(path.at(3), a));
  EXPECT_TRUE(viewer::same_camera(path.at(5), b));
}

TEST(ViewerCanvas, SrgbMatchesWritePngAndRoundTrips) {
  for (int i = 0; i <= 4096; ++i) {
    const float v = float(i) / 4096.0f;
    ASSERT_EQ(overlay::linear_to_srgb8(v), uint8_t(std::lround(render::linear_to_srgb(v) * 255.0f))) << v;
  }
  overlay::Canvas c(256, 1);
  for (int i = 0; i < 256; ++i) c.at(i, 0) = {uint8_t(i), uint8_t(255 - i), uint8_t(i / 2), 255};
  overlay::Canvas back;
  back.set_from_linear(c.to_linear());
  for (int i = 0; i < 256; ++i) ASSERT_EQ(back.at(i, 0), c.at(i, 0)) << i;
  // Text draws something inside its reported box and nothing outside.
  overlay::Canvas t(64, 16, {0, 0, 0, 255});
  const glm::ivec2 size = t.text(1, 1, "Hi 42", {255, 255, 255, 255});
  int lit = 0, outside = 0;
  for (uint32_t y = 0; y < 16; ++y)
    for (uint32_t x = 0; x < 64; ++x)
      if (t.at(x, y).r) (int(x) <= size.x + 1 && int(y) <= size.y + 1 ? lit : outside)++;
  EXPECT_GT(lit, 10);
  EXPECT_EQ(outside, 0);
}

// The HUD's legend: a swatch of each type's colour, at most kHudLegendMax of them; type_legend
// labels a type by its name, else its input id, with the renderer's colour or the palette's.
TEST(ViewerHud, LegendShowsASwatchPerType) {
  auto entry = [](int32_t id, const char* name) {
    store::TypeEntry t{};
    t.input_id = id;
    std::strncpy(t.name, name, sizeof(t.name) - 1);
    return t;
  };
  const std::vector<store::TypeEntry> types = {entry(1, ""), entry(2, "Cu")};
  const std::vector<glm::vec3> colors = {{1.0f, 0.0f, 0.0f}};
  const auto legend = overlay::type_legend(types, colors);
  ASSERT_EQ(legend.size(), 2u);
  EXPECT_EQ(legend[0].label, "1");
  EXPECT_EQ(legend[0].color, overlay::Rgba8(255, 0, 0, 255));
  EXPECT_EQ(legend[1].label, "Cu");
  const glm::vec3 p1 = render::type_color_srgb(1);
  EXPECT_EQ(legend[1].color, overlay::Rgba8(uint8_t(std::lround(p1.r * 255)), uint8_t(std::lround(p1.g * 255)),
                                           uint8_t(std::lround(p1.b * 255)), 255));

  auto swatches = [](size_t count) {
    viewer::HudState s;
    for (size_t i = 0; i < count; ++i) s.legend.push_back({std::to_string(i + 1), {0, 255, 0, 255}});
    overlay::Canvas c(640, 400, {0, 0, 0, 255});  // below 800 px: scale 1, 7 x 7 swatches
    viewer::draw_hud(c, s);
    size_t green = 0;
    for (uint32_t y = 0; y < c.height(); ++y)
      for (uint32_t x = 0; x < c.width(); ++x) green += c.at(x, y) == overlay::Rgba8(0, 255, 0, 255);
    return green;
  };
  EXPECT_EQ(swatches(0), 0u);
  EXPECT_EQ(swatches(2), 2u * 49u);
  EXPECT_EQ(swatches(viewer::kHudLegendMax + 5), viewer::kHudLegendMax * 49u);
}

// With --color-by the legend is the colormap: five swatches from viridis(0) to viridis(1), the
// first labelled with the axis, each with its coordinate.
TEST(ViewerHud, ColormapLegendLabelsTheRange) {
  const auto legend = overlay::colormap_legend(render::color_axis_name(2), {-10.0, 30.0});
  ASSERT_EQ(legend.size(), 5u);
  EXPECT_EQ(legend[0].label, "z -10");
  EXPECT_EQ(legend[2].label, "10");
  EXPECT_EQ(legend[4].label, "30");
  EXPECT_EQ(overlay::colormap_legend("c_pe", {-7.0, -5.0})[0].label, "c_pe -7");
  for (int k : {0, 4}) {
    const glm::dvec3 c = render::viridis_srgb(0.25 * k);
    EXPECT_EQ(legend[k].color, overlay::Rgba8(uint8_t(std::lround(c.r * 255)), uint8_t(std::lround(c.g * 255)),
                                             uint8_t(std::lround(c.b * 255)), 255));
  }
}

// The HUD's cache line counts the nodes --slice left out (never read) and the nodes a series step
// carried (the first wave) when there are any.
TEST(ViewerHud, CacheLineCountsSlicedOutNodes) {
  viewer::HudState s;
  s.streaming = true;
  s.cache.nodes = 305;
  const auto has = [](const std::vector<std::string>& lines, const std::string& text) {
    return std::any_of(lines.begin(), lines.end(), [&](const std::string& l) { return l.find(text) != std::string::npos; });
  };
  EXPECT_FALSE(has(viewer::hud_lines(s), "left out"));
  s.cache.nodes_left_out = 193;
  EXPECT_TRUE(has(viewer::hud_lines(s), "nodes 0/305  in flight 0  left out 193"));
  // ... and, after a series step, the nodes of the first wave carried from the frame before.
  EXPECT_FALSE(has(viewer::hud_lines(s), "carried"));
  s.cache.carried_nodes = 12;
  EXPECT_TRUE(has(viewer::hud_lines(s), "left out 193  carried 12"));
}

// --threshold: a line of its own, with the property's name (none without a threshold).
TEST(ViewerHud, ThresholdLine) {
  viewer::HudState s;
  s.store_name = "v.mds";
  const size_t without = viewer::hud_lines(s).size();
  s.threshold = "threshold c_pe -6:";
  const auto lines = viewer::hud_lines(s);
  ASSERT_EQ(lines.size(), without + 1);
  EXPECT_EQ(lines[1], "threshold c_pe -6:");
}

// The picked particle's line stays on the HUD while the message row fades (and is not shown
// twice while the message is the pick).
TEST(ViewerHud, PickLineStaysAfterTheMessage) {
  viewer::HudState s;
  const size_t plain = viewer::hud_lines(s).size();
  s.pick = "pick 10,12: node 3 particle 7 (store index 1507) type 1 at (1, 2, 3) r 0.5, distance 9";
  s.message = s.pick;
  auto lines = viewer::hud_lines(s);
  ASSERT_EQ(lines.size(), plain + 1);
  EXPECT_EQ(lines.back(), s.pick);
  s.message.clear();  // faded
  lines = viewer::hud_lines(s);
  ASSERT_EQ(lines.size(), plain + 1);
  EXPECT_EQ(lines.back(), s.pick);
  s.message = "saved mdstream-view-1.png";
  lines = viewer::hud_lines(s);
  ASSERT_EQ(lines.size(), plain + 2);
  EXPECT_EQ(lines[lines.size() - 2], s.pick);
  EXPECT_EQ(lines.back(), s.message);
}

// A series' frame line comes second (under the store's name), only for a series.
TEST(ViewerHud, SeriesLineUnderTheStoreName) {
  viewer::HudState s;
  s.store_name = "run.0002.mds";
  const size_t plain = viewer::hud_lines(s).size();
  s.series = "series frame 2 (3/5)  time 100";
  const auto lines = viewer::hud_lines(s);
  ASSERT_EQ(lines.size(), plain + 1);
  EXPECT_EQ(lines[0].rfind("run.0002.mds", 0), 0u);
  EXPECT_EQ(lines[1], s.series);
}

// The view line says when ambient occlusion is on (key L), with its radius.
TEST(ViewerHud, StateNamesACappedViewApartFromAConvergedOne) {
  viewer::HudState s;
  s.spp = 4;
  s.report.samples = 2;
  s.report.complete = true;
  auto state_line = [&] {
    for (const std::string& l : viewer::hud_lines(s))
      if (l.rfind("samples ", 0) == 0) return l;
    return std::string();
  };
  s.report.settled = true;  // culling stopped at --max-iterations, not converged
  EXPECT_NE(state_line().find("culling capped (--max-iterations), accumulating"), std::string::npos) << state_line();
  s.report.converged = true;
  EXPECT_NE(state_line().find("converged, accumulating"), std::string::npos) << state_line();
  s.idle = true;
  EXPECT_NE(state_line().find("converged (idle)"), std::string::npos) << state_line();
  s.report.converged = false;
  EXPECT_NE(state_line().find("culling capped (idle)"), std::string::npos) << state_line();
}

TEST(ViewerHud, ViewLineShowsAmbientOcclusion) {
  viewer::HudState s;
  s.fov_y_deg = 40.0;
  s.view_name = "normal";
  const auto view_line = [&] {
    for (const std::string& l : viewer::hud_lines(s))
      if (l.rfind("persp", 0) == 0) return l;
    return std::string();
  };
  EXPECT_EQ(view_line(), "persp fov 40  view: normal");
  s.ao_radius = 1.5;
  EXPECT_EQ(view_line(), "persp fov 40  view: normal  ao r 1.5");
}

// The classes debug view (in memory over meshlet boxes, streaming over node boxes): a box's
// projection takes its class colour, pixels outside every box are only dimmed, and a pixel
// covered by boxes of two classes mixes them.
TEST(ViewerDebugViews, ClassBoxesColourTheirProjection) {
  render::Camera cam = home_camera();
  render::fit_clip_planes(cam, unit_bounds());
  const uint32_t W = 80, H = 60;
  overlay::Canvas c(W, H, {90, 90, 90, 255});
  const std::vector<viewer::Box> boxes = {{{0, 4, 4}, {3, 6, 6}},    // left: O
                                          {{7, 4, 4}, {10, 6, 6}},   // right: P
                                          {{7, 4, 0}, {10, 6, 2}},   // behind the right one: O
                                          {{4, 8, 4}, {6, 9, 6}}};   // top: class 7, skipped
  const std::vector<uint32_t> classes = {MDS_CULL_CLASS_O, MDS_CULL_CLASS_P, MDS_CULL_CLASS_O, 7};
  viewer::draw_class_boxes(c, cam, boxes, classes);
  const viewer::Projector proj(cam, W, H);
  auto pixel = [&](glm::dvec3 p) {
    glm::dvec3 q;
    EXPECT_TRUE(proj.project(p, q));
    return c.at(uint32_t(q.x), uint32_t(q.y));
  };
  const overlay::Rgba8 left = pixel({1.5, 5, 5}), right = pixel({8.5, 5, 5}), top = pixel({5, 8.5, 5});
  EXPECT_GT(left.r, 2 * left.g) << "O is red";
  EXPECT_GT(right.r, 60) << "P and O mixed: red and green";
  EXPECT_GT(right.g, 60);
  EXPECT_EQ(top, (overlay::Rgba8{30, 30, 30, 255})) << "an out-of-range class is not drawn, only dimmed";
  EXPECT_EQ(c.at(0, 0), (overlay::Rgba8{30, 30, 30, 255}));
}

// The slice keys' arithmetic: a step is 1/50 of the box's extent along the normal, the distance
// is rounded to 1/1000 of a step in decimal (so the printed spec is short), `invert` toggles, and
// the options read back as the same slices.
TEST(ViewerSliceKeys, StepAlongTheNormalRoundedAndPrintedAsOptions) {
  const double lo[3] = {0.3664, 0.0, -10.0}, hi[3] = {57.9114, 20.0, 30.0};
  const store::Slice z{{0.0, 0.0, 1.0}, 1.5, 0.0, false};
  EXPECT_DOUBLE_EQ(viewer::extent_along(z, lo, hi), 40.0);
  const store::Slice x{{1.0, 0.0, 0.0}, 1.5, 2.0, false};
  const store::Slice back = viewer::step_slice(x, -1.0, false, lo, hi);  // step 57.545 / 50 = 1.1509
  // 1.5 - 1.1509 = 0.34909999999999997, rounded to 3 decimals (1/1000 of a step is 0.00115).
  EXPECT_EQ(back.distance, 0.349);
  EXPECT_EQ(back.width, 2.0);
  EXPECT_FALSE(back.invert);
  const store::Slice fine = viewer::step_slice(x, 0.1 * 7, true, lo, hi);
  EXPECT_EQ(fine.distance, 2.306);  // 1.5 + 0.7 * 1.1509 = 2.30563
  EXPECT_TRUE(fine.invert);
  EXPECT_FALSE(viewer::step_slice(fine, 0.0, true, lo, hi).invert);
  const store::Slice diagonal{{0.6, 0.8, 0.0}, 0.0, 0.0, false};
  EXPECT_NEAR(viewer::extent_along(diagonal, lo, hi), 0.6 * 57.545 + 0.8 * 20.0, 1e-12);
  EXPECT_EQ(viewer::slice_options({back, fine}), "--slice 1,0,0,0.349,2 --slice 1,0,0,2.306,2,invert");
  for (const store::Slice& s : {back, fine}) {
    auto again = store::parse_slice(store::slice_spec(s));
    ASSERT_TRUE(again.ok()) << store::slice_spec(s);
    EXPECT_EQ(*again, s);
  }
}

// The threshold keys' arithmetic: a step is 1/50 of the property's range to two digits; pressed
// one at a time the keys give what they give pressed together; an open end moves from
// that end of the range, an unmoved end stays open; bounds are rounded to 1/1000 of a step and
// stop at each other; `invert` toggles; the option reads back as the same threshold.
TEST(ViewerThresholdKeys, StepTheBoundsOverThePropertysRange) {
  const double pmin = -7.2228, pmax = -3.9343;  // step 3.2885 / 50 = 0.06577, to 2 digits 0.066
  EXPECT_DOUBLE_EQ(viewer::threshold_step(pmin, pmax), 0.066);
  EXPECT_DOUBLE_EQ(viewer::threshold_step(0.0, 641.3), 13.0);
  EXPECT_EQ(viewer::threshold_step(2.0, 2.0), 0.0);
  constexpr double inf = std::numeric_limits<double>::infinity();
  const store::Threshold up = viewer::step_threshold(std::nullopt, 2.0, 0.0, false, pmin, pmax);
  EXPECT_EQ(up.lo, -7.0908);  // -7.2228 + 2 x 0.066, to 1/1000 of a step (5 decimals)
  EXPECT_EQ(up.hi, inf);
  EXPECT_FALSE(up.invert);
  EXPECT_EQ(viewer::threshold_option(up), "--threshold -7.0908:");
  const store::Threshold from_spec = viewer::step_threshold(store::Threshold{-6.0, inf, false}, 0.0, -1.0, true, pmin, pmax);
  EXPECT_EQ(from_spec.lo, -6.0);
  EXPECT_EQ(from_spec.hi, -4.0003);  // -3.9343 - 0.066
  EXPECT_TRUE(from_spec.invert);
  EXPECT_EQ(viewer::threshold_option(from_spec), "--threshold -6:-4.0003,invert");
  // Seven presses one at a time (one a frame) equal seven at once.
  std::optional<store::Threshold> one = std::nullopt;
  for (int i = 0; i < 7; ++i) one = viewer::step_threshold(one, 1.0, 0.0, false, pmin, pmax);
  EXPECT_EQ(one->lo, viewer::step_threshold(std::nullopt, 7.0, 0.0, false, pmin, pmax).lo);
  // Past the other bound: stops at it.
  const store::Threshold met = viewer::step_threshold(store::Threshold{-6.0, -5.9, false}, 5.0, 0.0, false, pmin, pmax);
  EXPECT_EQ(met.lo, -5.9);
  EXPECT_EQ(met.hi, -5.9);
  for (const store::Threshold& t : {up, from_spec, met}) {
    auto again = store::parse_threshold(store::threshold_spec(t));
    ASSERT_TRUE(again.ok()) << store::threshold_spec(t);
    EXPECT_EQ(*again, t);
  }
}

// V cycles through what the store has; M through the colormaps; the options say it for render.
TEST(ViewerColorKeys, CycleVisitsWhatTheStoreHas) {
  auto cycle = [](bool has_color, bool has_property) {
    std::vector<std::string> seen;
    render::ColorBy c;  // type
    for (int i = 0; i < 7; ++i) {
      c = viewer::next_color_by(c, has_color, has_property);
      seen.push_back(viewer::color_options(c, "c_pe"));
    }
    return seen;
  };
  EXPECT_EQ(cycle(false, false),
            (std::vector<std::string>{"--color-by x", "--color-by y", "--color-by z", "--color-by type", "--color-by x",
                                      "--color-by y", "--color-by z"}));
  EXPECT_EQ(cycle(true, true),
            (std::vector<std::string>{"--color-by color", "--color-by x", "--color-by y", "--color-by z",
                                      "--color-by c_pe", "--color-by type", "--color-by color"}));
  render::ColorBy c;
  c.axis = 2;
  c.lo = 1;
  c.hi = 5;
  c.map = viewer::next_colormap(render::Colormap::viridis);
  EXPECT_EQ(viewer::color_options(c, ""), "--color-by z --color-range 1:5 --colormap plasma");
  EXPECT_EQ(viewer::next_colormap(render::Colormap::gray), render::Colormap::viridis);
  EXPECT_EQ(viewer::next_color_by(c, false, false).lo, 0.0);  // the next axis takes its own range
}

}  // namespace
