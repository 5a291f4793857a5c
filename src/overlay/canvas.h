// An 8-bit sRGB frame on the CPU: conversion of the renderer's linear float image (the same sRGB
// encoding and rounding as render::write_png), and the 2D drawing that the viewer's HUD and debug
// views and the colour legend of rendered images need: blended rectangles, lines, text
// (stb_easy_font quads rasterized here).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "core/result.h"
#include "render/renderer.h"

namespace mds::overlay {

using Rgba8 = glm::u8vec4;

// The panels drawn into rendered images (colour legend, text label): translucent black, light text.
inline const Rgba8 kPanelFill{0, 0, 0, 150};
inline const Rgba8 kPanelText{235, 235, 235, 255};

// Pixels [x0, x1) x [y0, y1) of an image; empty when x0 >= x1 or y0 >= y1.
struct PixelBox {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x0 >= x1 || y0 >= y1; }
  bool operator==(const PixelBox&) const = default;
};

class Canvas {
 public:
  Canvas() = default;
  Canvas(uint32_t width, uint32_t height, Rgba8 fill = {0, 0, 0, 255});

  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  const uint8_t* data() const { return reinterpret_cast<const uint8_t*>(pixels_.data()); }
  Rgba8& at(uint32_t x, uint32_t y) { return pixels_[size_t(y) * width_ + x]; }
  const Rgba8& at(uint32_t x, uint32_t y) const { return pixels_[size_t(y) * width_ + x]; }

  // rgb -> sRGB 8-bit (rounded as write_png does), alpha 255. Sizes must match or the canvas is resized.
  void set_from_linear(const render::FrameImage& image);
  // The canvas resampled to width x height, nearest pixel (dynamic resolution: the reduced
  // render of a moving camera shown at the window's size; blocky, but no blur and no cost).
  Canvas resized_nearest(uint32_t width, uint32_t height) const;
  // The canvas as a linear float image (exact round trip through set_from_linear and write_png).
  render::FrameImage to_linear() const;

  // Alpha-blends `c` (c.a = opacity) over the pixel; clipped.
  void blend(int x, int y, Rgba8 c);
  void fill_rect(int x0, int y0, int x1, int y1, Rgba8 c);  // [x0, x1) x [y0, y1)
  void line(glm::dvec2 a, glm::dvec2 b, Rgba8 c);           // clipped to the canvas
  void circle(glm::dvec2 center, double radius, Rgba8 c);    // filled disc, blended
  // Text with stb_easy_font at (x, y) top-left, `scale` pixels per font unit; '\n' starts a line,
  // a byte outside printable ASCII (UTF-8, a tab) is drawn as '?'.
  // Returns the bounding box size in pixels.
  glm::ivec2 text(int x, int y, std::string_view s, Rgba8 c, int scale = 1);
  static glm::ivec2 text_size(std::string_view s, int scale = 1);

 private:
  uint32_t width_ = 0, height_ = 0;
  std::vector<Rgba8> pixels_;
};

// Lookup: sRGB 8-bit value of a linear intensity (same as lround(linear_to_srgb(v) * 255)).
uint8_t linear_to_srgb8(float v);

// Draws on the pixels of `box` of a linear image (render::FrameImage, as Renderer::render returns
// it), for the panels written into rendered images (colour legend, text label): the box's pixels
// become 8-bit sRGB (linear_to_srgb8, as Canvas::set_from_linear) on a canvas of the box alone,
// `draw` paints on it with (0, 0) at the box's top-left corner, and they go back in linear with
// coverage (alpha) 1; every other pixel stays as it was, to the bit, and only the box is
// converted. Precondition: the box lies inside the image (nothing is drawn for an empty box).
void draw_on_linear(render::FrameImage& image, PixelBox box, const std::function<void(Canvas&)>& draw);

// Writes the canvas as an 8-bit PNG (render::write_png, atomically).
Status write_canvas_png(const std::filesystem::path& path, const Canvas& canvas);

}  // namespace mds::overlay
