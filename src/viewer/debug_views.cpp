#include "viewer/debug_views.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "culling/culling_constants.h"

namespace mds::viewer {

const char* debug_view_name(DebugView v) {
  switch (v) {
    case DebugView::normal: return "normal";
    case DebugView::classes: return "occlusion classes";
    case DebugView::cull_depth: return "cull buffer depth";
    case DebugView::confidence: return "cull buffer confidence";
  }
  return "?";
}

Rgba8 class_color(uint32_t cls) {
  switch (cls) {
    case MDS_CULL_CLASS_P: return {40, 200, 60, 255};
    case MDS_CULL_CLASS_L: return {230, 220, 40, 255};
    case MDS_CULL_CLASS_M: return {240, 140, 30, 255};
    case MDS_CULL_CLASS_O: return {220, 40, 40, 255};
    default: return {200, 0, 200, 255};
  }
}

Projector::Projector(const render::Camera& camera, uint32_t width, uint32_t height) : width_(width), height_(height) {
  const double aspect = double(width) / double(std::max(height, 1u));
  view_proj_ = render::projection_matrix(camera, aspect) * render::view_matrix(camera, glm::dvec3(0.0));
}

bool Projector::project(const glm::dvec3& world, glm::dvec3& out) const {
  const glm::dvec4 c = view_proj_ * glm::dvec4(world, 1.0);
  if (c.w <= 1e-12) return false;
  const glm::dvec3 ndc = glm::dvec3(c) / c.w;
  out = {(ndc.x * 0.5 + 0.5) * width_, (ndc.y * 0.5 + 0.5) * height_, ndc.z};
  return true;
}

void draw_box(Canvas& canvas, const Projector& proj, const render::Camera& camera, const Box& box, Rgba8 color) {
  const glm::dmat4 view = render::view_matrix(camera, glm::dvec3(0.0));
  const double near = std::max(camera.near, 1e-12);
  glm::dvec3 corner[8];
  for (int i = 0; i < 8; ++i)
    corner[i] = {(i & 1) ? box.max.x : box.min.x, (i & 2) ? box.max.y : box.min.y, (i & 4) ? box.max.z : box.min.z};
  static const int edges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                   {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  const glm::dmat4 inv_view = glm::inverse(view);
  for (const auto& e : edges) {
    glm::dvec3 a = glm::dvec3(view * glm::dvec4(corner[e[0]], 1.0));
    glm::dvec3 b = glm::dvec3(view * glm::dvec4(corner[e[1]], 1.0));
    if (!camera.ortho) {
      // Clip against the near plane (view space looks along -z).
      if (-a.z < near && -b.z < near) continue;
      if (-a.z < near) a = b + (a - b) * ((-near - b.z) / (a.z - b.z));
      if (-b.z < near) b = a + (b - a) * ((-near - a.z) / (b.z - a.z));
    }
    glm::dvec3 pa, pb;
    if (!proj.project(glm::dvec3(inv_view * glm::dvec4(a, 1.0)), pa) ||
        !proj.project(glm::dvec3(inv_view * glm::dvec4(b, 1.0)), pb))
      continue;
    canvas.line({pa.x, pa.y}, {pb.x, pb.y}, color);
  }
}

void draw_class_boxes(Canvas& canvas, const render::Camera& camera, std::span<const Box> boxes,
                      std::span<const uint32_t> classes) {
  // Red dominating a pixel: most of what lies behind it is culled.
  const uint32_t w = canvas.width(), h = canvas.height();
  std::vector<std::array<uint32_t, 4>> count(size_t(w) * h, std::array<uint32_t, 4>{});
  const Projector proj(camera, w, h);
  const size_t n = std::min(classes.size(), boxes.size());
  for (size_t i = 0; i < n; ++i) {
    if (classes[i] > 3) continue;
    const Box& b = boxes[i];
    glm::dvec3 lo(1e300), hi(-1e300);
    bool ok = true;
    for (int c = 0; c < 8 && ok; ++c) {
      const glm::dvec3 p((c & 1) ? b.max.x : b.min.x, (c & 2) ? b.max.y : b.min.y, (c & 4) ? b.max.z : b.min.z);
      glm::dvec3 q(0.0);
      ok = proj.project(p, q) && q.z >= 0.0;
      lo = glm::min(lo, q);
      hi = glm::max(hi, q);
    }
    if (!ok) continue;
    const int x0 = std::max(int(std::floor(lo.x)), 0), x1 = std::min(int(std::ceil(hi.x)), int(w));
    const int y0 = std::max(int(std::floor(lo.y)), 0), y1 = std::min(int(std::ceil(hi.y)), int(h));
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) ++count[size_t(y) * w + x][classes[i]];
  }
  uint32_t peak = 1;
  for (const auto& c : count) peak = std::max(peak, c[0] + c[1] + c[2] + c[3]);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const auto& c = count[size_t(y) * w + x];
      const uint32_t total = c[0] + c[1] + c[2] + c[3];
      Rgba8& d = canvas.at(x, y);
      d = Rgba8(d.r / 3, d.g / 3, d.b / 3, 255);
      if (total == 0) continue;
      glm::dvec3 mix(0.0);
      for (uint32_t k = 0; k < 4; ++k) mix += glm::dvec3(glm::dvec3(class_color(k))) * (double(c[k]) / total);
      const double a = 0.45 + 0.5 * std::sqrt(double(total) / peak);
      canvas.blend(int(x), int(y), Rgba8(uint8_t(mix.r), uint8_t(mix.g), uint8_t(mix.b), uint8_t(255 * a)));
    }
}

void draw_meshlet_classes(Canvas& canvas, const render::Camera& camera, const render::SceneData& scene,
                          const std::vector<uint32_t>& classes) {
  std::vector<Box> boxes(scene.meshlets.size());
  std::vector<uint32_t> cls(boxes.size(), 4u);  // empty meshlets: skipped
  for (size_t i = 0; i < boxes.size() && i < classes.size(); ++i) {
    const auto& m = scene.meshlets[i];
    boxes[i] = {scene.origin + glm::dvec3(m.aabb_min), scene.origin + glm::dvec3(m.aabb_max)};
    if (m.particle_count != 0) cls[i] = classes[i];
  }
  draw_class_boxes(canvas, camera, boxes, cls);
}

void draw_cull_depth(Canvas& canvas, const std::vector<glm::vec4>& pixel_state, double near, double far) {
  const uint32_t w = canvas.width(), h = canvas.height();
  if (pixel_state.size() < size_t(2) * w * h) return;
  const double span = std::max(far - near, 1e-30);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const glm::vec4 cb = pixel_state[2 * (size_t(y) * w + x) + 1];
      const float d = cb.x;
      if (!(d < float(MDS_CULL_DEPTH_EMPTY) * 0.5f) || !std::isfinite(d) || cb.y <= 0.0f) {
        canvas.at(x, y) = {10, 20, 60, 255};
        continue;
      }
      const double t = std::clamp((double(d) - near) / span, 0.0, 1.0);
      const auto g = uint8_t(std::lround(255.0 * std::pow(1.0 - t, 2.0)));
      canvas.at(x, y) = {g, g, g, 255};
    }
}

void draw_confidence(Canvas& canvas, const std::vector<glm::vec4>& pixel_state, double c_occ) {
  const uint32_t w = canvas.width(), h = canvas.height();
  if (pixel_state.size() < size_t(2) * w * h) return;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const float c = std::clamp(pixel_state[2 * (size_t(y) * w + x) + 1].y, 0.0f, 1.0f);
      const auto g = uint8_t(std::lround(255.0f * c));
      canvas.at(x, y) = c >= float(c_occ) ? Rgba8(255, uint8_t(g / 3), uint8_t(g / 3), 255) : Rgba8(g, g, g, 255);
    }
}

void draw_histogram(Canvas& canvas, const std::vector<float>& histograms, const std::vector<glm::vec2>& ranges,
                    uint32_t bins, uint32_t x, uint32_t y) {
  const uint32_t w = canvas.width(), h = canvas.height();
  if (bins == 0 || x >= w || y >= h) return;
  const size_t pix = size_t(y) * w + x;
  if (histograms.size() < (pix + 1) * bins || ranges.size() <= pix) return;
  // Stored cumulative: per-bin counts are differences.
  std::vector<double> counts(bins);
  double prev = 0.0, peak = 0.0;
  for (uint32_t b = 0; b < bins; ++b) {
    const double c = histograms[pix * bins + b];
    counts[b] = std::max(c - prev, 0.0);
    prev = c;
    peak = std::max(peak, counts[b]);
  }
  const int bw = std::max(2, int(std::min<uint32_t>(w / 2, 256) / bins));
  const int ph = int(std::max(h / 4, 24u));
  const int x0 = int(w) - bw * int(bins) - 6, y1 = int(h) - 14;
  canvas.fill_rect(x0 - 4, y1 - ph - 16, int(w) - 2, int(h) - 2, {0, 0, 0, 170});
  for (uint32_t b = 0; b < bins; ++b) {
    const int bh = peak > 0 ? int(std::lround(counts[b] / peak * ph)) : 0;
    canvas.fill_rect(x0 + int(b) * bw, y1 - bh, x0 + int(b + 1) * bw - 1, y1, {120, 190, 255, 230});
  }
  const glm::vec2 r = ranges[pix];
  const std::string label = r.y > r.x ? fmt::format("px {},{}  d {:.3g}..{:.3g}  n {:.0f}", x, y, r.x, r.y, prev)
                                      : fmt::format("px {},{}  empty", x, y);
  canvas.text(x0, y1 - ph - 13, label, {255, 255, 255, 255});
  // Cursor cross.
  canvas.line({double(x) - 4, double(y)}, {double(x) + 4, double(y)}, {255, 0, 255, 255});
  canvas.line({double(x), double(y) - 4}, {double(x), double(y) + 4}, {255, 0, 255, 255});
}

}  // namespace mds::viewer
