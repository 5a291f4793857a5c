// The coordinate tripod of rendered images (overlay/axis_tripod.h; `render --axes`): the axes as
// known cameras see them, drawn far to near; the panel in its corner and after the legend and
// label there; on an image, each axis's colour where its direction points and nothing outside the
// panel changed.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "overlay/axis_tripod.h"
#include "overlay/canvas.h"
#include "overlay/image_panels.h"

namespace mds {
namespace {

using overlay::LegendCorner;
using overlay::PixelBox;

render::Camera camera(glm::dvec3 eye, glm::dvec3 up = {0, 1, 0}) {
  render::Camera c;
  c.eye = eye;
  c.target = glm::dvec3(0.0);
  c.up = up;
  return c;
}

const overlay::TripodAxis& axis(const std::array<overlay::TripodAxis, 3>& a, char name) {
  for (const auto& x : a)
    if (x.name == name) return x;
  ADD_FAILURE() << name;
  return a[0];
}

TEST(AxisTripod, AxesAsKnownCamerasSeeThem) {
  // Front view (looking along -z, y up): x right, y up (screen y down), z at the viewer, drawn last.
  const auto front = overlay::tripod_axes(camera({0, 0, 10}));
  EXPECT_EQ(front[2].name, 'z');
  EXPECT_NEAR(axis(front, 'x').screen.x, 1.0, 1e-12);
  EXPECT_NEAR(axis(front, 'x').screen.y, 0.0, 1e-12);
  EXPECT_NEAR(axis(front, 'y').screen.y, -1.0, 1e-12);
  EXPECT_NEAR(glm::length(axis(front, 'z').screen), 0.0, 1e-12);
  EXPECT_NEAR(axis(front, 'z').toward, 1.0, 1e-12);
  // From above, looking down -y with -z up on screen: x right, z down the screen, y at the viewer.
  const auto top = overlay::tripod_axes(camera({0, 10, 0}, {0, 0, -1}));
  EXPECT_EQ(top[2].name, 'y');
  EXPECT_NEAR(axis(top, 'x').screen.x, 1.0, 1e-12);
  EXPECT_NEAR(axis(top, 'z').screen.y, 1.0, 1e-12);
  // From behind (looking along +z): x points left, z away from the viewer (drawn first).
  const auto back = overlay::tripod_axes(camera({0, 0, -10}));
  EXPECT_EQ(back[0].name, 'z');
  EXPECT_NEAR(axis(back, 'x').screen.x, -1.0, 1e-12);
  EXPECT_NEAR(axis(back, 'z').toward, -1.0, 1e-12);
  // An oblique view: every axis foreshortened, the drawing order by the component toward the viewer.
  const auto ob = overlay::tripod_axes(camera({1, 1.4, 1.2}));
  for (const auto& a : ob) {
    EXPECT_LT(glm::length(a.screen), 1.0);
    EXPECT_NEAR(glm::length(a.screen) * glm::length(a.screen) + a.toward * a.toward, 1.0, 1e-12);
  }
  EXPECT_LE(ob[0].toward, ob[1].toward);
  EXPECT_LE(ob[1].toward, ob[2].toward);
}

// An up along the view direction (a path's interpolation can give one): finite axes, still unit
// vectors split between the image plane and the view direction.
TEST(AxisTripod, UpAlongTheViewStillGivesAxes) {
  for (const auto& a : overlay::tripod_axes(camera({0, 10, 0}, {0, 1, 0}))) {
    EXPECT_TRUE(std::isfinite(a.screen.x) && std::isfinite(a.screen.y) && std::isfinite(a.toward)) << a.name;
    EXPECT_NEAR(glm::dot(a.screen, a.screen) + a.toward * a.toward, 1.0, 1e-12) << a.name;
  }
}

TEST(AxisTripod, ThePanelSitsInItsCornerAfterTheOthers) {
  EXPECT_TRUE(overlay::tripod_box(640, 400, LegendCorner::off).empty());
  const PixelBox tl = overlay::tripod_box(640, 400, LegendCorner::top_left);
  EXPECT_EQ(tl.x0, 8);
  EXPECT_EQ(tl.y0, 8);
  EXPECT_EQ(tl.x1 - tl.x0, tl.y1 - tl.y0);  // square
  EXPECT_GT(tl.x1 - tl.x0, 2 * 20);         // two axis lengths at scale 1
  const PixelBox br = overlay::tripod_box(640, 400, LegendCorner::bottom_right);
  EXPECT_EQ(br.x1, 640 - 8);
  EXPECT_EQ(br.y1, 400 - 8);
  const PixelBox big = overlay::tripod_box(1600, 1200, LegendCorner::top_left);
  EXPECT_EQ(big.x1 - big.x0, 3 * (tl.x1 - tl.x0 - 1) + 1);  // scale 3
  EXPECT_EQ(overlay::tripod_box(640, 400, LegendCorner::top_left, {8, 8, 50, 30}).y0, 30 + 4);
  EXPECT_EQ(overlay::tripod_box(640, 400, LegendCorner::bottom_left, {8, 300, 50, 392}).y1, 300 - 4);
  const PixelBox tiny = overlay::tripod_box(20, 10, LegendCorner::bottom_right);
  EXPECT_GE(tiny.x0, 0);
  EXPECT_LE(tiny.y1, 10);

  // Legend, label and tripod in one corner: stacked in that order, apart.
  overlay::ColorLegend legend;
  legend.title = "type";
  legend.entries = {{"1", {200, 120, 50, 255}}};
  for (const LegendCorner c : {LegendCorner::top_right, LegendCorner::bottom_left}) {
    render::FrameImage img{400, 300, std::vector<float>(4 * 400 * 300, 0.05f)};
    const auto b = overlay::overlay_panels(img, {legend, c, "step 5", c, c, camera({0, 0, 10})});
    ASSERT_FALSE(b.axes.empty());
    const bool top = c == LegendCorner::top_right;
    EXPECT_EQ(top ? b.label.y0 : b.label.y1, top ? b.legend.y1 + 4 : b.legend.y0 - 4);
    EXPECT_EQ(top ? b.axes.y0 : b.axes.y1, top ? b.label.y1 + 4 : b.label.y0 - 4);
  }
  // No camera: no tripod.
  render::FrameImage img{400, 300, std::vector<float>(4 * 400 * 300, 0.05f)};
  EXPECT_TRUE(overlay::overlay_panels(img, {legend, LegendCorner::off, "", LegendCorner::top_left, LegendCorner::top_left,
                                            std::nullopt})
                  .axes.empty());
}

// Front view: red right of the centre on its row, green above it, blue (z, at the viewer) only
// around the centre; every pixel outside the panel as it was.
TEST(AxisTripod, EachAxisIsDrawnWhereItPoints) {
  const render::FrameImage before{320, 240, std::vector<float>(4 * 320 * 240, 0.02f)};
  render::FrameImage img = before;
  const PixelBox b = overlay::overlay_tripod(img, camera({0, 0, 10}), LegendCorner::top_right);
  ASSERT_FALSE(b.empty());
  const auto axes = overlay::tripod_axes(camera({0, 0, 10}));
  const int cx = (b.x0 + b.x1) / 2, cy = (b.y0 + b.y1) / 2;
  const auto is = [&](int x, int y, char name) {
    const glm::vec4 p = img.at(uint32_t(x), uint32_t(y));
    const overlay::Rgba8 c = axis(axes, name).color;
    return overlay::linear_to_srgb8(p.r) == c.r && overlay::linear_to_srgb8(p.g) == c.g &&
           overlay::linear_to_srgb8(p.b) == c.b;
  };
  int red_right = 0, red_left = 0, green_up = 0, green_down = 0, blue_far = 0;
  for (int y = b.y0; y < b.y1; ++y)
    for (int x = b.x0; x < b.x1; ++x) {
      if (is(x, y, 'x') && std::abs(y - cy) <= 2) red_right += x > cx + 2, red_left += x < cx - 2;
      if (is(x, y, 'y') && std::abs(x - cx) <= 2) green_up += y < cy - 2, green_down += y > cy + 2;
      if (is(x, y, 'z')) blue_far += std::abs(x - cx) > 8 || std::abs(y - cy) > 8;
    }
  EXPECT_GE(red_right, 15);
  EXPECT_EQ(red_left, 0);
  EXPECT_GE(green_up, 15);
  EXPECT_EQ(green_down, 0);
  EXPECT_EQ(blue_far, 0);
  for (uint32_t y = 0; y < 240; ++y)
    for (uint32_t x = 0; x < 320; ++x)
      if (int(x) < b.x0 || int(x) >= b.x1 || int(y) < b.y0 || int(y) >= b.y1) {
        ASSERT_EQ(img.at(x, y), before.at(x, y));
      }
}

}  // namespace
}  // namespace mds
