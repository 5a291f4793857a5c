#include "overlay/image_panels.h"

#include <array>

namespace mds::overlay {

PanelBoxes overlay_panels(render::FrameImage& image, const ImagePanels& p) {
  std::array<PixelBox, 5> last{};  // per corner (LegendCorner's values): the last panel drawn there
  const auto after = [&](LegendCorner c) { return last[size_t(c)]; };
  const auto drawn = [&](LegendCorner c, PixelBox b) {
    if (!b.empty()) last[size_t(c)] = b;
    return b;
  };
  PanelBoxes b;
  b.legend = drawn(p.legend_corner, overlay_color_legend(image, p.legend, p.legend_corner));
  b.label = drawn(p.label_corner, overlay_text_label(image, p.label, p.label_corner, after(p.label_corner)));
  if (p.camera) b.axes = drawn(p.axes_corner, overlay_tripod(image, *p.camera, p.axes_corner, after(p.axes_corner)));
  return b;
}

}  // namespace mds::overlay
