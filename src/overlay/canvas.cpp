#include "overlay/canvas.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "render/image_io.h"
#include "render/scene.h"

// stb_easy_font: bitmap font as quads (header-only, from libstb-dev). Its functions are static.
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wconversion"
#endif
#include <stb/stb_easy_font.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace mds::overlay {

namespace {

// thresholds[v] = smallest linear value that rounds to sRGB8 v (v >= 1), found by bisection on
// the very function write_png uses, so the result equals lround(linear_to_srgb(x) * 255).
const std::array<float, 256>& srgb_thresholds() {
  static const std::array<float, 256> t = [] {
    std::array<float, 256> th{};
    th[0] = -INFINITY;
    auto enc = [](float x) { return int(std::lround(render::linear_to_srgb(x) * 255.0f)); };
    for (int v = 1; v < 256; ++v) {
      float lo = 0.0f, hi = 1.0f;  // enc(lo) < v <= enc(hi)
      for (int i = 0; i < 64; ++i) {
        const float mid = 0.5f * (lo + hi);
        if (mid == lo || mid == hi) break;
        if (enc(mid) >= v) hi = mid; else lo = mid;
      }
      th[v] = hi;
    }
    return th;
  }();
  return t;
}

const std::array<float, 256>& srgb8_to_linear_table() {
  static const std::array<float, 256> t = [] {
    std::array<float, 256> l{};
    const auto& th = srgb_thresholds();
    for (int v = 0; v < 256; ++v) {
      float x = render::srgb_to_linear(float(v) / 255.0f);
      // Make the round trip exact: inside [th[v], th[v+1]).
      if (v > 0 && x < th[v]) x = th[v];
      if (v < 255 && x >= th[v + 1]) x = std::nextafter(th[v + 1], 0.0f);
      l[v] = x;
    }
    return l;
  }();
  return t;
}

}  // namespace

uint8_t linear_to_srgb8(float v) {
  if (!(v > 0.0f)) return 0;  // also NaN
  const auto& th = srgb_thresholds();
  return uint8_t(std::upper_bound(th.begin() + 1, th.end(), v) - th.begin() - 1);
}

Canvas::Canvas(uint32_t width, uint32_t height, Rgba8 fill)
    : width_(width), height_(height), pixels_(size_t(width) * height, fill) {}

Canvas Canvas::resized_nearest(uint32_t width, uint32_t height) const {
  if (width == width_ && height == height_) return *this;
  Canvas out(width, height);
  if (width_ == 0 || height_ == 0) return out;
  std::vector<uint32_t> sx(width);
  for (uint32_t x = 0; x < width; ++x) sx[x] = std::min(width_ - 1, uint32_t((2 * uint64_t(x) + 1) * width_ / (2 * uint64_t(width))));
  for (uint32_t y = 0; y < height; ++y) {
    const uint32_t syy = std::min(height_ - 1, uint32_t((2 * uint64_t(y) + 1) * height_ / (2 * uint64_t(height))));
    const Rgba8* src = &pixels_[size_t(syy) * width_];
    Rgba8* dst = &out.pixels_[size_t(y) * width];
    for (uint32_t x = 0; x < width; ++x) dst[x] = src[sx[x]];
  }
  return out;
}

void Canvas::set_from_linear(const render::FrameImage& image) {
  if (image.width != width_ || image.height != height_) *this = Canvas(image.width, image.height);
  const size_t n = size_t(width_) * height_;
  for (size_t i = 0; i < n; ++i) {
    const float* p = &image.rgba[4 * i];
    pixels_[i] = Rgba8(linear_to_srgb8(p[0]), linear_to_srgb8(p[1]), linear_to_srgb8(p[2]), 255);
  }
}

render::FrameImage Canvas::to_linear() const {
  render::FrameImage img;
  img.width = width_;
  img.height = height_;
  img.rgba.resize(size_t(width_) * height_ * 4);
  const auto& lut = srgb8_to_linear_table();
  for (size_t i = 0; i < pixels_.size(); ++i) {
    img.rgba[4 * i + 0] = lut[pixels_[i].r];
    img.rgba[4 * i + 1] = lut[pixels_[i].g];
    img.rgba[4 * i + 2] = lut[pixels_[i].b];
    img.rgba[4 * i + 3] = 1.0f;
  }
  return img;
}

void Canvas::blend(int x, int y, Rgba8 c) {
  if (x < 0 || y < 0 || x >= int(width_) || y >= int(height_)) return;
  Rgba8& d = at(uint32_t(x), uint32_t(y));
  const int a = c.a;
  for (int k = 0; k < 3; ++k) d[k] = uint8_t((c[k] * a + d[k] * (255 - a) + 127) / 255);
}

void Canvas::fill_rect(int x0, int y0, int x1, int y1, Rgba8 c) {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, int(width_));
  y1 = std::min(y1, int(height_));
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) blend(x, y, c);
}

void Canvas::line(glm::dvec2 a, glm::dvec2 b, Rgba8 c) {
  // Liang-Barsky clip to the canvas, then a DDA.
  const double xmin = 0, ymin = 0, xmax = width_ - 1.0, ymax = height_ - 1.0;
  if (!std::isfinite(a.x) || !std::isfinite(a.y) || !std::isfinite(b.x) || !std::isfinite(b.y)) return;
  double t0 = 0, t1 = 1;
  const glm::dvec2 d = b - a;
  const double p[4] = {-d.x, d.x, -d.y, d.y};
  const double q[4] = {a.x - xmin, xmax - a.x, a.y - ymin, ymax - a.y};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0) {
      if (q[i] < 0) return;
    } else {
      const double t = q[i] / p[i];
      if (p[i] < 0) t0 = std::max(t0, t); else t1 = std::min(t1, t);
    }
  }
  if (t0 > t1) return;
  const glm::dvec2 s = a + t0 * d, e = a + t1 * d;
  const int steps = int(std::ceil(std::max(std::abs(e.x - s.x), std::abs(e.y - s.y)))) + 1;
  for (int i = 0; i <= steps; ++i) {
    const glm::dvec2 pt = s + (e - s) * (double(i) / steps);
    blend(int(std::lround(pt.x)), int(std::lround(pt.y)), c);
  }
}

void Canvas::circle(glm::dvec2 center, double radius, Rgba8 c) {
  const int x0 = int(std::floor(center.x - radius)), x1 = int(std::ceil(center.x + radius));
  const int y0 = int(std::floor(center.y - radius)), y1 = int(std::ceil(center.y + radius));
  if (x1 < 0 || y1 < 0 || x0 >= int(width_) || y0 >= int(height_)) return;
  const double r2 = radius * radius;
  for (int y = std::max(y0, 0); y <= std::min(y1, int(height_) - 1); ++y)
    for (int x = std::max(x0, 0); x <= std::min(x1, int(width_) - 1); ++x) {
      const double dx = x + 0.5 - center.x, dy = y + 0.5 - center.y;
      if (dx * dx + dy * dy <= r2) blend(x, y, c);
    }
}

namespace {

// stb_easy_font looks every byte up in a table of the printable ASCII characters (32..126) without
// a range check: any other byte (UTF-8, a tab, DEL) becomes '?', a newline stays.
std::string printable(std::string_view s) {
  std::string out(s);
  for (char& ch : out) {
    const unsigned char u = static_cast<unsigned char>(ch);
    if (ch != '\n' && (u < 32 || u > 126)) ch = '?';
  }
  return out;
}

}  // namespace

glm::ivec2 Canvas::text_size(std::string_view s, int scale) {
  std::string str = printable(s);
  return {stb_easy_font_width(str.data()) * scale, stb_easy_font_height(str.data()) * scale};
}

glm::ivec2 Canvas::text(int x, int y, std::string_view s, Rgba8 c, int scale) {
  std::string str = printable(s);
  // stb_easy_font: ~270 bytes of vertices per character at most; 4 vertices of 16 bytes per quad.
  std::vector<char> buf(str.size() * 300 + 64);
  unsigned char col[4] = {c.r, c.g, c.b, c.a};
  const int quads = stb_easy_font_print(0.0f, 0.0f, str.data(), col, buf.data(), int(buf.size()));
  struct Vertex {
    float x, y, z;
    unsigned char rgba[4];
  };
  const auto* v = reinterpret_cast<const Vertex*>(buf.data());
  for (int q = 0; q < quads; ++q) {
    const Vertex* quad = v + 4 * q;  // axis-aligned: corners 0 and 2 are opposite
    const int qx0 = x + int(std::lround(std::min(quad[0].x, quad[2].x) * scale));
    const int qx1 = x + int(std::lround(std::max(quad[0].x, quad[2].x) * scale));
    const int qy0 = y + int(std::lround(std::min(quad[0].y, quad[2].y) * scale));
    const int qy1 = y + int(std::lround(std::max(quad[0].y, quad[2].y) * scale));
    fill_rect(qx0, qy0, qx1, qy1, c);
  }
  return text_size(s, scale);
}

void draw_on_linear(render::FrameImage& image, PixelBox box, const std::function<void(Canvas&)>& draw) {
  if (box.empty()) return;
  const uint32_t bw = uint32_t(box.x1 - box.x0), bh = uint32_t(box.y1 - box.y0);
  Canvas canvas(bw, bh);
  for (uint32_t py = 0; py < bh; ++py)
    for (uint32_t px = 0; px < bw; ++px) {
      const float* p = &image.rgba[4 * (size_t(box.y0 + int(py)) * image.width + size_t(box.x0 + int(px)))];
      canvas.at(px, py) = Rgba8(linear_to_srgb8(p[0]), linear_to_srgb8(p[1]), linear_to_srgb8(p[2]), 255);
    }
  draw(canvas);
  const render::FrameImage drawn = canvas.to_linear();
  for (uint32_t py = 0; py < bh; ++py)
    std::copy_n(&drawn.rgba[4 * size_t(py) * bw], 4 * size_t(bw),
                &image.rgba[4 * (size_t(box.y0 + int(py)) * image.width + size_t(box.x0))]);  // alpha 1 (to_linear)
}

Status write_canvas_png(const std::filesystem::path& path, const Canvas& canvas) {
  if (canvas.width() == 0 || canvas.height() == 0)
    return make_error(Errc::internal, "{}: no frame to save yet", path.string());
  return render::write_png(path, canvas.to_linear());
}

}  // namespace mds::overlay
