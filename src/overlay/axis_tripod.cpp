#include "overlay/axis_tripod.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace mds::overlay {

namespace {

// The panel's layout at text scale s: axes of `len` pixels from the centre, a label beyond each tip.
struct Layout {
  int s = 1, pad = 4, margin = 8, gap = 4, len = 20, side = 0;
};

Layout layout(uint32_t height) {
  Layout y;
  y.s = std::max(1, int(height / 400));
  y.pad = 4 * y.s;
  y.margin = 8 * y.s;
  y.gap = 4 * y.s;
  y.len = 20 * y.s;
  const glm::ivec2 t = Canvas::text_size("x", y.s);
  y.side = 2 * (y.len + std::max(t.x, t.y) + y.pad) + 1;  // a label all round, odd: a centre pixel
  return y;
}

glm::ivec2 origin(const Layout& y, uint32_t width, uint32_t height, LegendCorner corner, PixelBox after) {
  return corner_origin({y.side, y.side}, y.margin, y.gap, width, height, corner, after);
}

}  // namespace

std::array<TripodAxis, 3> tripod_axes(const render::Camera& camera) {
  const glm::dvec3 f = glm::normalize(camera.target - camera.eye);
  glm::dvec3 side = glm::cross(f, camera.up);
  if (!(glm::length(side) > 1e-12)) {  // up along the view (a path's interpolation): the axis least along it
    const glm::dvec3 a = glm::abs(f);
    const glm::dvec3 up = a.x <= a.y && a.x <= a.z ? glm::dvec3(1, 0, 0) : a.y <= a.z ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
    side = glm::cross(f, up);
  }
  const glm::dvec3 r = glm::normalize(side);
  const glm::dvec3 u = glm::cross(r, f);
  std::array<TripodAxis, 3> a;
  const Rgba8 colors[3] = {{230, 70, 70, 255}, {90, 200, 90, 255}, {90, 140, 255, 255}};
  for (int k = 0; k < 3; ++k) {
    glm::dvec3 e(0.0);
    e[k] = 1.0;
    a[size_t(k)] = {char('x' + k), colors[k], {glm::dot(e, r), -glm::dot(e, u)}, -glm::dot(e, f)};
  }
  std::stable_sort(a.begin(), a.end(), [](const TripodAxis& p, const TripodAxis& q) { return p.toward < q.toward; });
  return a;
}

PixelBox tripod_box(uint32_t width, uint32_t height, LegendCorner corner, PixelBox after) {
  if (corner == LegendCorner::off || width == 0 || height == 0) return {};
  const Layout y = layout(height);
  return clipped_box(origin(y, width, height, corner, after), {y.side, y.side}, width, height);
}

namespace {

// The panel with its top-left corner at `o` in the canvas's coordinates (clipped to it).
void draw_panel(Canvas& canvas, const render::Camera& camera, const Layout& y, glm::ivec2 o) {
  canvas.fill_rect(o.x, o.y, o.x + y.side, o.y + y.side, kPanelFill);
  const glm::dvec2 c = glm::dvec2(o) + glm::dvec2(y.side / 2);
  for (const TripodAxis& a : tripod_axes(camera)) {
    const glm::dvec2 tip = c + a.screen * double(y.len);
    for (int dy = 0; dy < y.s + 1; ++dy)  // s + 1 pixels wide
      for (int dx = 0; dx < y.s + 1; ++dx) canvas.line(c + glm::dvec2(dx, dy), tip + glm::dvec2(dx, dy), a.color);
    // The label beyond the tip, centred on the axis's direction (at the centre for an axis
    // pointing at the viewer).
    const glm::ivec2 t = Canvas::text_size(std::string(1, a.name), y.s);
    const glm::dvec2 at = c + a.screen * double(y.len + y.gap + std::max(t.x, t.y) / 2) - glm::dvec2(t) / 2.0;
    canvas.text(int(std::lround(at.x)), int(std::lround(at.y)), std::string(1, a.name), a.color, y.s);
  }
}

}  // namespace

PixelBox draw_tripod(Canvas& canvas, const render::Camera& camera, LegendCorner corner, PixelBox after) {
  const PixelBox box = tripod_box(canvas.width(), canvas.height(), corner, after);
  if (box.empty()) return box;
  const Layout y = layout(canvas.height());
  draw_panel(canvas, camera, y, origin(y, canvas.width(), canvas.height(), corner, after));
  return box;
}

PixelBox overlay_tripod(render::FrameImage& image, const render::Camera& camera, LegendCorner corner, PixelBox after) {
  const PixelBox box = tripod_box(image.width, image.height, corner, after);
  if (box.empty()) return box;
  const Layout y = layout(image.height);
  const glm::ivec2 o = origin(y, image.width, image.height, corner, after) - glm::ivec2(box.x0, box.y0);
  draw_on_linear(image, box, [&](Canvas& canvas) { draw_panel(canvas, camera, y, o); });
  return box;
}

}  // namespace mds::overlay
