#include "overlay/color_legend.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "render/colormap.h"
#include "render/scene.h"

namespace mds::overlay {

namespace {

uint8_t byte_of(double x) { return uint8_t(std::lround(std::clamp(x, 0.0, 1.0) * 255.0)); }

Rgba8 colormap8(render::Colormap map, double t) {
  const glm::dvec3 c = render::colormap_srgb(map, t);
  return {byte_of(c.r), byte_of(c.g), byte_of(c.b), 255};
}

// The panel's layout at text scale s, relative to its top-left corner.
struct Layout {
  int s = 1;
  int line_h = 10, pad = 4, margin = 8, gap = 3;
  int swatch = 7;         // types: a swatch per row
  int bar_w = 10, bar_h = 0, bar_top = 0;  // colormap
  int tick = 2;
  size_t rows = 0;        // types: the rows drawn (a "+N" row included)
  std::string more;       // types: "+N" when entries exceed kLegendRowsMax
  int w = 0, h = 0;
};

Layout layout(const ColorLegend& l, uint32_t height) {
  Layout y;
  y.s = std::max(1, int(height / 400));
  const int s = y.s;
  y.line_h = 10 * s;
  y.pad = 4 * s;
  y.margin = 8 * s;
  y.gap = 3 * s;
  y.swatch = 7 * s;
  y.bar_w = 10 * s;
  y.tick = 2 * s;
  int content_w = Canvas::text_size(l.title, s).x;
  if (l.colormap) {
    y.bar_h = std::max(5 * y.line_h, int(0.3 * height));
    int label_w = 0;
    for (int k = 0; k <= 4; ++k) label_w = std::max(label_w, Canvas::text_size(colormap_tick(l.range, k), s).x);
    content_w = std::max(content_w, y.bar_w + y.tick + y.gap + label_w);
    // Room above and below the bar for half a label each (labels are centred on their rows).
    y.bar_top = y.pad + y.line_h + 4 * s;
    y.h = y.bar_top + y.bar_h + 4 * s + y.pad;
  } else {
    const size_t shown = std::min(l.entries.size(), kLegendRowsMax);
    if (l.entries.size() > shown) y.more = fmt::format("+{}", l.entries.size() - shown);
    y.rows = shown + (y.more.empty() ? 0 : 1);
    for (size_t i = 0; i < shown; ++i)
      content_w = std::max(content_w, y.swatch + y.gap + Canvas::text_size(l.entries[i].label, s).x);
    if (!y.more.empty()) content_w = std::max(content_w, Canvas::text_size(y.more, s).x);
    y.h = y.pad + y.line_h + int(y.rows) * y.line_h + y.pad;
  }
  y.w = y.pad + content_w + y.pad;
  return y;
}

// The panel's unclipped top-left corner.
glm::ivec2 origin(const Layout& y, uint32_t width, uint32_t height, LegendCorner corner) {
  return corner_origin({y.w, y.h}, y.margin, 0, width, height, corner);
}

}  // namespace

std::vector<LegendEntry> type_legend(std::span<const store::TypeEntry> types, std::span<const glm::vec3> colors_srgb,
                                     std::span<const uint8_t> shown) {
  std::vector<LegendEntry> l;
  for (size_t i = 0; i < types.size(); ++i) {
    if (i < shown.size() && !shown[i]) continue;
    const std::string name(types[i].name, strnlen(types[i].name, sizeof(types[i].name)));
    const glm::vec3 c = i < colors_srgb.size() ? colors_srgb[i] : render::type_color_srgb(uint32_t(i));
    l.push_back({name.empty() ? std::to_string(types[i].input_id) : name, Rgba8(byte_of(c.r), byte_of(c.g), byte_of(c.b), 255)});
  }
  return l;
}

std::string colormap_tick(glm::dvec2 range, int k) {
  return fmt::format("{:.3g}", range.x + 0.25 * k * (range.y - range.x));
}

std::vector<LegendEntry> colormap_legend(const std::string& name, glm::dvec2 range, render::Colormap map) {
  std::vector<LegendEntry> l;
  for (int k = 0; k <= 4; ++k) {
    const std::string v = colormap_tick(range, k);
    l.push_back({k == 0 ? name + " " + v : v, colormap8(map, 0.25 * k)});
  }
  return l;
}

Result<LegendCorner> parse_legend_corner(std::string_view s) {
  for (const LegendCorner c : {LegendCorner::off, LegendCorner::top_left, LegendCorner::top_right,
                               LegendCorner::bottom_left, LegendCorner::bottom_right})
    if (s == legend_corner_name(c)) return c;
  return make_error(Errc::invalid_argument, "'{}': expected off, top-left, top-right, bottom-left or bottom-right", s);
}

const char* legend_corner_name(LegendCorner c) {
  switch (c) {
    case LegendCorner::off: return "off";
    case LegendCorner::top_left: return "top-left";
    case LegendCorner::top_right: return "top-right";
    case LegendCorner::bottom_left: return "bottom-left";
    case LegendCorner::bottom_right: return "bottom-right";
  }
  return "off";
}

glm::ivec2 corner_origin(glm::ivec2 size, int margin, int gap, uint32_t width, uint32_t height, LegendCorner corner,
                         PixelBox after) {
  const bool left = corner == LegendCorner::top_left || corner == LegendCorner::bottom_left;
  const bool top = corner == LegendCorner::top_left || corner == LegendCorner::top_right;
  const int x = left ? margin : int(width) - margin - size.x;
  if (top) return {x, after.empty() ? margin : after.y1 + gap};
  return {x, (after.empty() ? int(height) - margin : after.y0 - gap) - size.y};
}

PixelBox clipped_box(glm::ivec2 o, glm::ivec2 size, uint32_t width, uint32_t height) {
  const PixelBox b{std::max(o.x, 0), std::max(o.y, 0), std::min(o.x + size.x, int(width)), std::min(o.y + size.y, int(height))};
  return b.empty() ? PixelBox{} : b;
}

PixelBox legend_box(const ColorLegend& legend, uint32_t width, uint32_t height, LegendCorner corner) {
  if (corner == LegendCorner::off || width == 0 || height == 0) return {};
  const Layout y = layout(legend, height);
  return clipped_box(origin(y, width, height, corner), {y.w, y.h}, width, height);
}

namespace {

// Draws the panel with its top-left corner at `o` in the canvas's coordinates (clipped to it).
void draw_panel(Canvas& canvas, const ColorLegend& legend, const Layout& y, glm::ivec2 o) {
  const int s = y.s;
  const Rgba8 text_color = kPanelText;
  canvas.fill_rect(o.x, o.y, o.x + y.w, o.y + y.h, kPanelFill);
  canvas.text(o.x + y.pad, o.y + y.pad, legend.title, text_color, s);
  const int x = o.x + y.pad;
  if (legend.colormap) {
    const int top = o.y + y.bar_top;
    for (int r = 0; r < y.bar_h; ++r) {
      const double t = y.bar_h > 1 ? 1.0 - double(r) / double(y.bar_h - 1) : 0.5;
      canvas.fill_rect(x, top + r, x + y.bar_w, top + r + 1, colormap8(legend.map, t));
    }
    for (int k = 4; k >= 0; --k) {
      const int row = top + int(std::lround((1.0 - 0.25 * k) * (y.bar_h - 1)));
      canvas.fill_rect(x + y.bar_w, row, x + y.bar_w + y.tick, row + s, text_color);
      canvas.text(x + y.bar_w + y.tick + y.gap, row - 3 * s, colormap_tick(legend.range, k), text_color, s);
    }
  } else {
    int row = o.y + y.pad + y.line_h;
    const size_t shown = y.rows - (y.more.empty() ? 0 : 1);
    for (size_t i = 0; i < shown; ++i, row += y.line_h) {
      canvas.fill_rect(x, row, x + y.swatch, row + y.swatch, legend.entries[i].color);
      canvas.text(x + y.swatch + y.gap, row, legend.entries[i].label, text_color, s);
    }
    if (!y.more.empty()) canvas.text(x, row, y.more, text_color, s);
  }
}

}  // namespace

PixelBox draw_color_legend(Canvas& canvas, const ColorLegend& legend, LegendCorner corner) {
  const PixelBox box = legend_box(legend, canvas.width(), canvas.height(), corner);
  if (box.empty()) return box;
  const Layout y = layout(legend, canvas.height());
  draw_panel(canvas, legend, y, origin(y, canvas.width(), canvas.height(), corner));
  return box;
}

PixelBox overlay_color_legend(render::FrameImage& image, const ColorLegend& legend, LegendCorner corner) {
  const PixelBox box = legend_box(legend, image.width, image.height, corner);
  if (box.empty()) return box;
  const Layout y = layout(legend, image.height);
  draw_on_linear(image, box, [&](Canvas& canvas) {
    draw_panel(canvas, legend, y, origin(y, image.width, image.height, corner) - glm::ivec2(box.x0, box.y0));
  });
  return box;
}

}  // namespace mds::overlay
