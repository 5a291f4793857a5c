// A text label drawn into rendered images: OVITO's "Text label" viewport layer with its
// attribute placeholders ([Timestep], [SourceFrame]), ParaView's "Annotate Time". `render --label
// TEXT` expands TEXT for each image (a series frame's time and index, a camera path's frame) and
// draws it on a translucent panel in a corner (--label-corner), below or above the colour legend
// when both take the same corner. docs/rendering.md, "Text label".
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "core/result.h"
#include "overlay/canvas.h"
#include "overlay/color_legend.h"
#include "render/renderer.h"

namespace mds::overlay {

// What a label's placeholders stand for in one image.
struct LabelFields {
  std::optional<double> time;  // {time}: the series frame's time (its simulation step); none for one store
  int64_t frame = 0;           // {frame}: the number -o's %d gets (series index, else the path's frame; 0 for one image)
  uint64_t particles = 0;      // {particles}: particles in the store
  std::string store;           // {store}: the store's file name
};

// `pattern` with its placeholders replaced, in fmt's syntax: {time}, {frame}, {particles},
// {store}, each with an optional format spec after a colon ({frame:04d}, {time:.1f}); {{ and }}
// are braces. A newline starts another line. Errc::invalid_argument quoting the pattern for an
// unknown placeholder or a bad spec, and for {time} when fields.time is empty.
Result<std::string> expand_label(std::string_view pattern, const LabelFields& fields);
inline constexpr size_t kLabelMaxBytes = 4096;  // an expanded label longer than this is refused ({frame:999999})

// Where the label's panel goes in a width x height image: in `corner` (not off), a margin from
// its edges, sized by the text at the legend's text scale (max(1, height / 400)); when `after`
// (the legend's box in the same corner) is not empty the panel goes below it (top corners) or
// above it (bottom corners), a gap away. Clipped to the image; empty for empty text.
PixelBox label_box(std::string_view text, uint32_t width, uint32_t height, LegendCorner corner, PixelBox after = {});
// Draws the label over a linear image in label_box (draw_on_linear: every pixel outside the box
// stays as it was, to the bit). Returns the box.
PixelBox overlay_text_label(render::FrameImage& image, std::string_view text, LegendCorner corner, PixelBox after = {});

}  // namespace mds::overlay
