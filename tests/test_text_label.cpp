// The text label of rendered images (overlay/text_label.h; `render --label`): placeholders
// expanded with fmt's syntax and refused by name, the panel's place in each corner and after a
// colour legend in the same corner, the text scale with the image height, and the overlay on a
// linear image that leaves every pixel outside the panel as it was, to the bit.
#include <gtest/gtest.h>

#include <string>

#include "overlay/canvas.h"
#include "overlay/color_legend.h"
#include "overlay/image_panels.h"
#include "overlay/text_label.h"

namespace mds {
namespace {

using overlay::Canvas;
using overlay::LabelFields;
using overlay::LegendCorner;
using overlay::PixelBox;

LabelFields fields(std::optional<double> time = 1500.0) {
  LabelFields f;
  f.time = time;
  f.frame = 7;
  f.particles = 4000;
  f.store = "run.0007.mds";
  return f;
}

std::string expand(const std::string& pattern, const LabelFields& f = fields()) {
  auto r = overlay::expand_label(pattern, f);
  return r.ok() ? *r : "error: " + r.error().message;
}

TEST(TextLabel, PlaceholdersExpandWithFmtSpecs) {
  EXPECT_EQ(expand("step {time}"), "step 1500");  // a whole step prints without a fraction
  EXPECT_EQ(expand("t = {time:.2f} ps", fields(0.25)), "t = 0.25 ps");
  EXPECT_EQ(expand("{time}", fields(0.25)), "0.25");
  EXPECT_EQ(expand("frame {frame:04d} of {store}"), "frame 0007 of run.0007.mds");
  EXPECT_EQ(expand("{particles} atoms"), "4000 atoms");
  EXPECT_EQ(expand("{{literal}} {frame}"), "{literal} 7");
  EXPECT_EQ(expand("two\nlines"), "two\nlines");
  EXPECT_EQ(expand("no placeholder"), "no placeholder");
  // One store has no time: a label without {time} expands, one with it is refused by name.
  EXPECT_EQ(expand("{store}: {frame}", fields(std::nullopt)), "run.0007.mds: 7");
  const std::string no_time = expand("step {time:06.0f}", fields(std::nullopt));
  EXPECT_NE(no_time.find("error: 'step {time:06.0f}': {time} is the time of a series frame"), std::string::npos)
      << no_time;
}

// Text outside printable ASCII (a degree sign in UTF-8, a tab) is drawn as '?', as the font has
// no glyph for it (it used to index past the font's table); an expansion over kLabelMaxBytes is refused.
TEST(TextLabel, BytesOutsideAsciiAndHugeWidths) {
  Canvas a(200, 40, {0, 0, 0, 255}), b(200, 40, {0, 0, 0, 255});
  const overlay::Rgba8 white{255, 255, 255, 255};
  EXPECT_EQ(a.text(2, 2, "T = 300 \xC2\xB0""C\tx", white), b.text(2, 2, "T = 300 ??C?x", white));
  for (uint32_t y = 0; y < 40; ++y)
    for (uint32_t x = 0; x < 200; ++x) ASSERT_EQ(a.at(x, y), b.at(x, y)) << x << "," << y;
  EXPECT_EQ(Canvas::text_size("\xff\x01"), Canvas::text_size("??"));
  const std::string e = expand("{frame:99999}");
  EXPECT_NE(e.find("more than 4096"), std::string::npos) << e.substr(0, 80);
  EXPECT_EQ(expand("{frame:9999999999999}").rfind("error: ", 0), 0u);
}

TEST(TextLabel, BadPatternsAreRefusedQuotingThem) {
  for (const char* bad : {"{timestep}", "{frame:q}", "open {frame", "close }", "{}", "{0}"}) {
    const std::string e = expand(bad);
    EXPECT_EQ(e.rfind(std::string("error: '") + bad + "': ", 0), 0u) << e;
    EXPECT_NE(e.find("{time}, {frame}, {particles} and {store}"), std::string::npos) << e;
  }
}

TEST(TextLabel, ThePanelSitsInItsCornerAndAfterALegendThere) {
  const std::string text = "step 1500";
  const glm::ivec2 t = Canvas::text_size(text);
  ASSERT_GT(t.x, 0);
  ASSERT_GT(t.y, 0);
  const PixelBox tl = overlay::label_box(text, 640, 400, LegendCorner::top_left);
  EXPECT_EQ(tl.x0, 8);  // the margin at scale 1
  EXPECT_EQ(tl.y0, 8);
  EXPECT_EQ(tl.x1 - tl.x0, t.x + 2 * 4);  // the text and 4 px of padding around it
  EXPECT_EQ(tl.y1 - tl.y0, t.y + 2 * 4);
  const PixelBox br = overlay::label_box(text, 640, 400, LegendCorner::bottom_right);
  EXPECT_EQ(br.x1, 640 - 8);
  EXPECT_EQ(br.y1, 400 - 8);
  const PixelBox tr = overlay::label_box(text, 640, 400, LegendCorner::top_right);
  EXPECT_EQ(tr.x1, 640 - 8);
  EXPECT_EQ(tr.y0, 8);
  // Scale 3 at a height of 1200: three times the text, margin and padding.
  const PixelBox big = overlay::label_box(text, 1600, 1200, LegendCorner::bottom_left);
  EXPECT_EQ(big.x0, 24);
  EXPECT_EQ(big.y1, 1200 - 24);
  EXPECT_EQ(big.x1 - big.x0, 3 * t.x + 2 * 12);
  // After a legend: below it in a top corner, above it in a bottom corner, 4 px away.
  const PixelBox legend{8, 8, 60, 50};
  const PixelBox below = overlay::label_box(text, 640, 400, LegendCorner::top_left, legend);
  EXPECT_EQ(below.y0, 50 + 4);
  EXPECT_EQ(below.x0, 8);
  const PixelBox low_legend{580, 300, 632, 392};
  const PixelBox above = overlay::label_box(text, 640, 400, LegendCorner::bottom_right, low_legend);
  EXPECT_EQ(above.y1, 300 - 4);
  EXPECT_EQ(above.x1, 632);
  // Nothing to draw, or an image smaller than the panel (clipped to it).
  EXPECT_TRUE(overlay::label_box("", 640, 400, LegendCorner::top_left).empty());
  EXPECT_TRUE(overlay::label_box(text, 640, 400, LegendCorner::off).empty());
  const PixelBox tiny = overlay::label_box(text, 16, 12, LegendCorner::bottom_right);
  EXPECT_GE(tiny.x0, 0);
  EXPECT_GE(tiny.y0, 0);
  EXPECT_LE(tiny.x1, 16);
  EXPECT_LE(tiny.y1, 12);
}

render::FrameImage filled(uint32_t w, uint32_t h, glm::vec4 c) {
  render::FrameImage img;
  img.width = w;
  img.height = h;
  img.rgba.resize(4 * size_t(w) * h);
  for (size_t i = 0; i < size_t(w) * h; ++i)
    for (int k = 0; k < 4; ++k) img.rgba[4 * i + size_t(k)] = c[k];
  return img;
}

bool inside(const PixelBox& b, uint32_t x, uint32_t y) { return int(x) >= b.x0 && int(x) < b.x1 && int(y) >= b.y0 && int(y) < b.y1; }

// Over a linear image: the box's pixels become the panel (text at kPanelText, the rest the
// translucent fill over the background), every other pixel keeps its bits, and the label's text
// decides the pixels (two labels of one size differ, one label drawn twice is the same).
TEST(TextLabel, TheOverlayChangesOnlyItsBox) {
  const glm::vec4 bg{0.3f, 0.5f, 0.7f, 0.25f};  // coverage < 1 outside: kept
  const render::FrameImage before = filled(320, 200, bg);
  render::FrameImage a = before;
  const PixelBox box = overlay::overlay_text_label(a, "frame 12", LegendCorner::bottom_left);
  ASSERT_FALSE(box.empty());
  EXPECT_EQ(box, overlay::label_box("frame 12", 320, 200, LegendCorner::bottom_left));
  size_t text = 0, panel = 0;
  const uint8_t fill_r = uint8_t(overlay::linear_to_srgb8(bg.r) * (255 - 150) / 255);  // about: black at 150/255
  for (uint32_t y = 0; y < 200; ++y)
    for (uint32_t x = 0; x < 320; ++x) {
      const glm::vec4 p = a.at(x, y);
      if (!inside(box, x, y)) {
        ASSERT_EQ(p, before.at(x, y)) << x << "," << y;
        continue;
      }
      EXPECT_EQ(p.a, 1.0f);
      const uint8_t r = overlay::linear_to_srgb8(p.r);
      text += r == overlay::kPanelText.r;
      panel += r <= fill_r + 1 && r + 1 >= fill_r;
    }
  EXPECT_GT(text, 40u);
  EXPECT_GT(panel, size_t(box.x1 - box.x0) * size_t(box.y1 - box.y0) / 2);
  render::FrameImage b = before, again = before;
  EXPECT_EQ(overlay::overlay_text_label(b, "frame 13", LegendCorner::bottom_left), box);
  EXPECT_NE(a.rgba, b.rgba);
  overlay::overlay_text_label(again, "frame 12", LegendCorner::bottom_left);
  EXPECT_EQ(a.rgba, again.rgba);
}

// Legend and label in one corner do not overlap; in two corners each sits at its own margin.
TEST(TextLabel, PanelsShareACornerWithoutOverlapping) {
  overlay::ColorLegend legend;
  legend.title = "type";
  legend.entries = {{"Cu", {200, 120, 50, 255}}, {"Ni", {90, 160, 220, 255}}};
  for (const LegendCorner c : {LegendCorner::top_left, LegendCorner::bottom_right}) {
    render::FrameImage img = filled(400, 300, {0.1f, 0.1f, 0.1f, 1.0f});
    const auto boxes = overlay::overlay_panels(img, {legend, c, "step 100", c});
    ASSERT_FALSE(boxes.legend.empty());
    ASSERT_FALSE(boxes.label.empty());
    const bool apart = boxes.label.y0 >= boxes.legend.y1 || boxes.label.y1 <= boxes.legend.y0;
    EXPECT_TRUE(apart) << overlay::legend_corner_name(c);
  }
  render::FrameImage img = filled(400, 300, {0.1f, 0.1f, 0.1f, 1.0f});
  const auto boxes = overlay::overlay_panels(img, {legend, LegendCorner::top_left, "step 100", LegendCorner::top_right});
  EXPECT_EQ(boxes.label, overlay::label_box("step 100", 400, 300, LegendCorner::top_right));
  EXPECT_EQ(boxes.legend, overlay::legend_box(legend, 400, 300, LegendCorner::top_left));
  // No label: only the legend is drawn.
  render::FrameImage none = filled(400, 300, {0.1f, 0.1f, 0.1f, 1.0f});
  EXPECT_TRUE(overlay::overlay_panels(none, {legend, LegendCorner::top_left, "", LegendCorner::top_left}).label.empty());
}

}  // namespace
}  // namespace mds
