// What the colours of an image mean: OVITO's colour legend layer, ParaView's scalar bar. The
// entries are shared with the viewer's HUD (its legend row); `render --color-legend CORNER` draws
// the legend into the written image: a panel in a corner with a title and either a swatch and a
// label per particle type, or a continuous colour bar of the colormap with five value labels.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "core/result.h"
#include "overlay/canvas.h"
#include "render/colormap.h"
#include "render/renderer.h"
#include "store/format.h"

namespace mds::overlay {

struct LegendEntry {
  std::string label;  // the type's name, else its input id (as `mdstream info` lists it); or a value
  Rgba8 color;        // sRGB 8-bit, as drawn (RenderSettings::type_colors_srgb, the colormap)
};

// The legend entries of the store's types with the colours the renderer uses; a type with
// shown[t] == 0 (--hide-type) is left out (empty `shown`: every type).
std::vector<LegendEntry> type_legend(std::span<const store::TypeEntry> types, std::span<const glm::vec3> colors_srgb,
                                     std::span<const uint8_t> shown = {});
// The legend of colour by coordinate or property (--color-by x|y|z|property): five swatches of
// the colormap (--colormap) at t = 0, 1/4, .., 1, labelled with their value (the first with `name` too: the
// axis, or the property's name).
std::vector<LegendEntry> colormap_legend(const std::string& name, glm::dvec2 range,
                                        render::Colormap map = render::Colormap::viridis);
// The value of colormap_legend's entry k (0..4) without the name: "{:.3g}" of lo + k/4 (hi - lo).
std::string colormap_tick(glm::dvec2 range, int k);

enum class LegendCorner : uint8_t { off, top_left, top_right, bottom_left, bottom_right };

// Where a panel of `size` pixels goes in a width x height image (legend, label, tripod): in
// `corner` (not off), `margin` in from its edges; when `after` (the panel before it in the same
// corner) is not empty, `gap` below it in a top corner or above it in a bottom one. Unclipped.
glm::ivec2 corner_origin(glm::ivec2 size, int margin, int gap, uint32_t width, uint32_t height, LegendCorner corner,
                         PixelBox after = {});
// The panel at `origin` of `size` clipped to the image; empty when nothing of it is inside.
PixelBox clipped_box(glm::ivec2 origin, glm::ivec2 size, uint32_t width, uint32_t height);
// "off", "top-left", "top-right", "bottom-left", "bottom-right"; Errc::invalid_argument naming
// them otherwise.
Result<LegendCorner> parse_legend_corner(std::string_view s);
const char* legend_corner_name(LegendCorner c);

// One image's legend: a title and either the colormap over `range` (colormap true) or `entries`.
struct ColorLegend {
  std::string title;
  bool colormap = false;
  glm::dvec2 range{0.0, 1.0};        // colormap: the values of t = 0 and t = 1
  render::Colormap map = render::Colormap::viridis;
  std::vector<LegendEntry> entries;  // types: one row each, at most kLegendRowsMax, then "+N"
};
inline constexpr size_t kLegendRowsMax = 24;

// Where the legend's panel goes in a width x height image: in `corner`, a margin from its edges,
// sized by the content at a text scale of max(1, height / 400) (clipped to the image; empty for
// LegendCorner::off). The colour bar is max(5 rows of text, 30 % of the height) tall.
PixelBox legend_box(const ColorLegend& legend, uint32_t width, uint32_t height, LegendCorner corner);
// Draws the legend on the canvas in legend_box: a translucent black panel, the title, then the
// bar (t = 1 at its top row, t = 0 at its bottom row; each row colormap_srgb(map, t) in 8 bits, as
// colormap_legend's swatches) with a label at t = 1, 3/4, .., 0, or a swatch and a label per
// entry. Returns the box.
PixelBox draw_color_legend(Canvas& canvas, const ColorLegend& legend, LegendCorner corner);
// The same over a linear image (render::FrameImage, as Renderer::render returns it): the box's
// pixels become the legend drawn over their 8-bit sRGB values (linear_to_srgb8, as
// Canvas::set_from_linear), back in linear, with coverage (alpha) 1; every other pixel stays as
// it was, to the bit, and only the box is converted.
PixelBox overlay_color_legend(render::FrameImage& image, const ColorLegend& legend, LegendCorner corner);

}  // namespace mds::overlay
