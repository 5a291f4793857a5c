// The viewer's colour keys; see color_keys.h.
#include "viewer/color_keys.h"

#include <fmt/format.h>

namespace mds::viewer {

render::ColorBy next_color_by(const render::ColorBy& c, bool has_color, bool has_property) {
  render::ColorBy n = c;
  n.lo = n.hi = 0.0;
  n.name.clear();
  if (c.by_color()) {
    n.particle_colors = false;
    n.axis = 0;
  } else if (c.axis < 0) {
    n.particle_colors = has_color;
    n.axis = has_color ? -1 : 0;
  } else if (c.axis < 2) {
    n.axis = c.axis + 1;
  } else if (c.axis == 2 && has_property) {
    n.axis = render::kColorByProperty;
  } else {
    n.axis = -1;
  }
  return n;
}

render::Colormap next_colormap(render::Colormap m) {
  constexpr int kCount = int(render::Colormap::gray) + 1;
  return render::Colormap((int(m) + 1) % kCount);
}

std::string color_options(const render::ColorBy& c, const std::string& property_name) {
  if (c.by_color()) return "--color-by color";
  if (c.by_type()) return "--color-by type";
  std::string s = fmt::format("--color-by {}", c.by_property() ? property_name : render::color_axis_name(c.axis));
  if (c.lo < c.hi) s += fmt::format(" --color-range {}:{}", c.lo, c.hi);
  if (c.map != render::Colormap::viridis) s += fmt::format(" --colormap {}", render::colormap_name(c.map));
  return s;
}

}  // namespace mds::viewer
