// The colour legend of rendered images (overlay/color_legend.h; `render --color-legend`): where
// its panel goes, the colormap bar's rows against render::colormap_srgb, a swatch per type in its
// colour, the "+N" row past kLegendRowsMax, the text scale with the image height, and the
// overlay on a linear image that leaves every pixel outside the panel as it was, to the bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "overlay/canvas.h"
#include "overlay/color_legend.h"
#include "render/colormap.h"

namespace mds {
namespace {

using overlay::Canvas;
using overlay::ColorLegend;
using overlay::LegendCorner;
using overlay::Rgba8;

Rgba8 colormap8(render::Colormap map, double t) {
  const glm::dvec3 c = render::colormap_srgb(map, t);
  auto b = [](double x) { return uint8_t(std::lround(std::clamp(x, 0.0, 1.0) * 255.0)); };
  return {b(c.r), b(c.g), b(c.b), 255};
}

ColorLegend colormap(glm::dvec2 range, render::Colormap map = render::Colormap::viridis) {
  ColorLegend l;
  l.title = "z";
  l.colormap = true;
  l.range = range;
  l.map = map;
  return l;
}

ColorLegend types(size_t n) {
  ColorLegend l;
  l.title = "type";
  for (size_t i = 0; i < n; ++i)
    l.entries.push_back({std::to_string(i + 1), Rgba8(uint8_t(10 + i), 200, uint8_t(250 - i), 255)});
  return l;
}

size_t count(const Canvas& c, Rgba8 v) {
  size_t n = 0;
  for (uint32_t y = 0; y < c.height(); ++y)
    for (uint32_t x = 0; x < c.width(); ++x) n += c.at(x, y) == v;
  return n;
}

// Pixels of `c` outside box that differ from `fill`.
size_t changed_outside(const Canvas& c, const overlay::PixelBox& b, Rgba8 fill) {
  size_t n = 0;
  for (uint32_t y = 0; y < c.height(); ++y)
    for (uint32_t x = 0; x < c.width(); ++x) {
      const bool inside = int(x) >= b.x0 && int(x) < b.x1 && int(y) >= b.y0 && int(y) < b.y1;
      n += !inside && c.at(x, y) != fill;
    }
  return n;
}

TEST(ColorLegend, CornersParseAndPlaceThePanel) {
  for (const char* name : {"off", "top-left", "top-right", "bottom-left", "bottom-right"}) {
    auto c = overlay::parse_legend_corner(name);
    ASSERT_TRUE(c.ok()) << name;
    EXPECT_STREQ(overlay::legend_corner_name(*c), name);
  }
  auto bad = overlay::parse_legend_corner("middle");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("top-right"), std::string::npos) << bad.error().message;

  const ColorLegend l = types(3);
  EXPECT_TRUE(overlay::legend_box(l, 640, 400, LegendCorner::off).empty());
  const auto tl = overlay::legend_box(l, 640, 400, LegendCorner::top_left);
  const auto br = overlay::legend_box(l, 640, 400, LegendCorner::bottom_right);
  EXPECT_EQ(tl.x0, 8);  // the margin at scale 1
  EXPECT_EQ(tl.y0, 8);
  EXPECT_EQ(br.x1, 640 - 8);
  EXPECT_EQ(br.y1, 400 - 8);
  EXPECT_EQ(tl.x1 - tl.x0, br.x1 - br.x0);
  EXPECT_EQ(tl.y1 - tl.y0, br.y1 - br.y0);
  // Title and three rows of 10 px, 4 px of padding above and below.
  EXPECT_EQ(tl.y1 - tl.y0, 4 + 10 + 3 * 10 + 4);
  // An image smaller than the panel: the box is clipped to it.
  const auto tiny = overlay::legend_box(colormap({0, 1}), 16, 12, LegendCorner::bottom_right);
  EXPECT_GE(tiny.x0, 0);
  EXPECT_GE(tiny.y0, 0);
  EXPECT_LE(tiny.x1, 16);
  EXPECT_LE(tiny.y1, 12);
  Canvas small(16, 12, {0, 0, 0, 255});
  overlay::draw_color_legend(small, colormap({0, 1}), LegendCorner::bottom_right);  // clipped, no write outside
}

// The bar: one column through it holds the map at 1 in its first row and at 0 in its last, and
// every row between at t = 1 - (row - first) / (last - first); five rows of text at least.
// Viridis (the default) and magma (--colormap).
TEST(ColorLegend, TheBarRunsFromTheMapAtOneAtTheTopToZeroAtTheBottom) {
  for (const render::Colormap map : {render::Colormap::viridis, render::Colormap::magma}) {
    SCOPED_TRACE(render::colormap_name(map));
    const auto map8 = [map](double t) { return colormap8(map, t); };
    const Rgba8 fill{0, 0, 0, 255};
    Canvas c(640, 400, fill);
    const auto box = overlay::draw_color_legend(c, colormap({-10.0, 30.0}, map), LegendCorner::top_right);
    ASSERT_FALSE(box.empty());
    EXPECT_EQ(changed_outside(c, box, fill), 0u);
    const uint32_t x = uint32_t(box.x0 + 4 + 5);  // the padding, then the middle of the 10 px bar
    int first = -1, last = -1;
    for (int y = box.y0; y < box.y1; ++y) {
      if (first < 0 && c.at(x, uint32_t(y)) == map8(1.0)) first = y;
      if (c.at(x, uint32_t(y)) == map8(0.0)) last = y;
    }
    ASSERT_GE(first, 0);
    ASSERT_GT(last, first);
    EXPECT_GE(last - first + 1, 5 * 10);
    EXPECT_EQ(last - first + 1, int(0.3 * 400));  // 30 % of the height
    for (int y = first; y <= last; ++y)
      ASSERT_EQ(c.at(x, uint32_t(y)), map8(1.0 - double(y - first) / double(last - first))) << y;
    // The labels right of the bar: light text.
    size_t text = 0;
    for (int y = box.y0; y < box.y1; ++y)
      for (int xx = int(x) + 10; xx < box.x1; ++xx) text += c.at(uint32_t(xx), uint32_t(y)) == Rgba8(235, 235, 235, 255);
    EXPECT_GT(text, 50u);
  }
  EXPECT_EQ(overlay::colormap_tick({-10.0, 30.0}, 0), "-10");
  EXPECT_EQ(overlay::colormap_tick({-10.0, 30.0}, 2), "10");
  EXPECT_EQ(overlay::colormap_tick({-10.0, 30.0}, 4), "30");
}

// A swatch per type in its colour: 7 x 7 pixels at scale 1 (height < 800), 21 x 21 at scale 3
// (height 1200); at most kLegendRowsMax of them, then "+N".
TEST(ColorLegend, ASwatchPerTypeAndTheRestCounted) {
  const Rgba8 fill{0, 0, 0, 255};
  for (const auto& [height, side] : {std::pair{400u, 7u}, std::pair{1200u, 21u}}) {
    Canvas c(900, height, fill);
    const ColorLegend l = types(3);
    const auto box = overlay::draw_color_legend(c, l, LegendCorner::bottom_left);
    EXPECT_EQ(changed_outside(c, box, fill), 0u);
    for (const auto& e : l.entries) EXPECT_EQ(count(c, e.color), side * side) << height;
  }
  Canvas c(640, 400, fill);
  const ColorLegend many = types(overlay::kLegendRowsMax + 6);
  overlay::draw_color_legend(c, many, LegendCorner::top_left);
  size_t drawn = 0;
  for (const auto& e : many.entries) drawn += count(c, e.color) == 49u;
  EXPECT_EQ(drawn, overlay::kLegendRowsMax);
}

// On a linear image: the pixels outside the panel keep their floats; inside, alpha (coverage)
// is 1 and the panel darkens what it covers.
TEST(ColorLegend, TheOverlayChangesOnlyThePanel) {
  render::FrameImage img;
  img.width = 200;
  img.height = 120;
  img.rgba.resize(size_t(img.width) * img.height * 4);
  for (size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = (i % 4 == 3) ? float(i % 7) / 7.0f : float(i % 97) / 96.0f;
  const render::FrameImage before = img;
  EXPECT_TRUE(overlay::overlay_color_legend(img, types(2), LegendCorner::off).empty());
  EXPECT_EQ(std::memcmp(img.rgba.data(), before.rgba.data(), img.rgba.size() * sizeof(float)), 0);
  const auto box = overlay::overlay_color_legend(img, colormap({0.0, 1.0}), LegendCorner::bottom_left);
  ASSERT_FALSE(box.empty());
  size_t inside = 0, darker = 0;
  for (uint32_t y = 0; y < img.height; ++y)
    for (uint32_t x = 0; x < img.width; ++x) {
      const size_t i = 4 * (size_t(y) * img.width + x);
      if (int(x) >= box.x0 && int(x) < box.x1 && int(y) >= box.y0 && int(y) < box.y1) {
        ++inside;
        EXPECT_EQ(img.rgba[i + 3], 1.0f);
        darker += img.rgba[i] < before.rgba[i];
      } else {
        ASSERT_EQ(std::memcmp(&img.rgba[i], &before.rgba[i], 4 * sizeof(float)), 0) << x << "," << y;
      }
    }
  EXPECT_EQ(inside, size_t(box.x1 - box.x0) * size_t(box.y1 - box.y0));
  EXPECT_GT(darker, inside / 3);
}

}  // namespace
}  // namespace mds
