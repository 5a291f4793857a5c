// The viewer's colour keys (V: what colours the particles, M: the colormap), as OVITO's colour
// coding is switched interactively. No window: tests/test_viewer.cpp checks them.
#pragma once

#include <string>

#include "render/colormap.h"

namespace mds::viewer {

// The choice after `c` (resolved: axis -1 .. kColorByProperty) in the order type -> the
// particles' own colours (only with has_color) -> x -> y -> z -> the property (only with
// has_property) -> type. The range goes back to the data's (lo = hi = 0); the colormap stays.
render::ColorBy next_color_by(const render::ColorBy& c, bool has_color, bool has_property);

// The colormap after c.map, in render::Colormap's order, wrapping around.
render::Colormap next_colormap(render::Colormap m);

// "--color-by z --colormap plasma": the options that give `render` (and `view`) this choice;
// the range only where it was given (lo < hi). property_name: the store's property, by its name.
std::string color_options(const render::ColorBy& c, const std::string& property_name);

}  // namespace mds::viewer
