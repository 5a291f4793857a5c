#include "overlay/text_label.h"

#include <algorithm>

#include <fmt/args.h>
#include <fmt/format.h>

namespace mds::overlay {

namespace {

// fmt also takes positional fields ({}, {0}), which would print whichever field came first:
// every placeholder must name one. Returns the offending field's offset, or npos.
size_t unnamed_field(std::string_view p) {
  for (size_t i = 0; i < p.size(); ++i) {
    if (p[i] != '{') continue;
    if (i + 1 < p.size() && p[i + 1] == '{') {
      ++i;  // an escaped brace
      continue;
    }
    const char c = i + 1 < p.size() ? p[i + 1] : '}';
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_')) return i;
  }
  return std::string_view::npos;
}

Result<std::string> format_with(std::string_view pattern, const LabelFields& f, bool with_time) {
  fmt::dynamic_format_arg_store<fmt::format_context> args;
  if (with_time) args.push_back(fmt::arg("time", f.time.value_or(0.0)));
  args.push_back(fmt::arg("frame", f.frame));
  args.push_back(fmt::arg("particles", f.particles));
  args.push_back(fmt::arg("store", f.store));
  try {
    std::string out = fmt::vformat(pattern, args);
    if (out.size() > kLabelMaxBytes)
      return make_error(Errc::invalid_argument, "{} bytes expanded, more than {}", out.size(), kLabelMaxBytes);
    return out;
  } catch (const std::exception& e) {  // fmt::format_error, or a width too large to allocate
    return make_error(Errc::invalid_argument, "{}", e.what());
  }
}

// The panel's layout at the legend's text scale s.
struct Layout {
  int s = 1, pad = 4, margin = 8, gap = 4;
  int w = 0, h = 0;
};

Layout layout(std::string_view text, uint32_t height) {
  Layout y;
  y.s = std::max(1, int(height / 400));
  y.pad = 4 * y.s;
  y.margin = 8 * y.s;
  y.gap = 4 * y.s;
  const glm::ivec2 t = Canvas::text_size(text, y.s);
  y.w = t.x + 2 * y.pad;
  y.h = t.y + 2 * y.pad;
  return y;
}

// The panel's unclipped top-left corner.
glm::ivec2 origin(const Layout& y, uint32_t width, uint32_t height, LegendCorner corner, PixelBox after) {
  return corner_origin({y.w, y.h}, y.margin, y.gap, width, height, corner, after);
}

}  // namespace

Result<std::string> expand_label(std::string_view pattern, const LabelFields& fields) {
  auto all = format_with(pattern, fields, true);
  if (const size_t at = unnamed_field(pattern); at != std::string_view::npos)
    all = make_error(Errc::invalid_argument, "a placeholder without a name at character {}", at + 1);
  if (!all.ok())
    return make_error(Errc::invalid_argument,
                      "'{}': {}; the placeholders are {{time}}, {{frame}}, {{particles}} and {{store}}, a format after "
                      "a colon ({{frame:04d}}), {{{{ and }}}} for braces",
                      pattern, all.error().message);
  if (fields.time) return all;
  auto without = format_with(pattern, fields, false);
  if (!without.ok())
    return make_error(Errc::invalid_argument,
                      "'{}': {{time}} is the time of a series frame (a .series index lists it): one store has none",
                      pattern);
  return without;
}

PixelBox label_box(std::string_view text, uint32_t width, uint32_t height, LegendCorner corner, PixelBox after) {
  if (corner == LegendCorner::off || text.empty() || width == 0 || height == 0) return {};
  const Layout y = layout(text, height);
  return clipped_box(origin(y, width, height, corner, after), {y.w, y.h}, width, height);
}

PixelBox overlay_text_label(render::FrameImage& image, std::string_view text, LegendCorner corner, PixelBox after) {
  const PixelBox box = label_box(text, image.width, image.height, corner, after);
  if (box.empty()) return box;
  const Layout y = layout(text, image.height);
  const glm::ivec2 o = origin(y, image.width, image.height, corner, after) - glm::ivec2(box.x0, box.y0);
  draw_on_linear(image, box, [&](Canvas& canvas) {
    canvas.fill_rect(o.x, o.y, o.x + y.w, o.y + y.h, kPanelFill);
    canvas.text(o.x + y.pad, o.y + y.pad, text, kPanelText, y.s);
  });
  return box;
}

}  // namespace mds::overlay
