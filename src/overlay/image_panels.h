// The panels `render` draws into an image, in one place: the colour legend (--color-legend), the
// text label (--label) and the coordinate tripod (--axes). Panels that take the same corner stack
// in that order, each a gap after the one before (below it in a top corner, above it in a bottom
// one). Every pixel outside the panels stays as it was, to the bit.
#pragma once

#include <optional>
#include <string>

#include "overlay/axis_tripod.h"
#include "overlay/color_legend.h"
#include "overlay/text_label.h"
#include "render/camera.h"
#include "render/renderer.h"

namespace mds::overlay {

struct ImagePanels {
  ColorLegend legend;
  LegendCorner legend_corner = LegendCorner::off;
  std::string label;  // expanded (expand_label); empty: none
  LegendCorner label_corner = LegendCorner::top_left;
  LegendCorner axes_corner = LegendCorner::off;
  std::optional<render::Camera> camera;  // the image's camera: the tripod's axes (none: no tripod)
};
struct PanelBoxes {
  PixelBox legend, label, axes;
};
PanelBoxes overlay_panels(render::FrameImage& image, const ImagePanels& panels);

}  // namespace mds::overlay
