// What stays fixed over the frames of a store series (store/series.h) so that an animation of
// it does not jump: the default camera frames the bounds of every frame, and a colour map
// without --color-range spans the data of every frame (OVITO's "adjust range (all frames)";
// ParaView rescales over all timesteps on request). Used by `render` and `view` on a .series.
#pragma once

#include <span>

#include <glm/glm.hpp>

#include "core/result.h"
#include "render/camera.h"
#include "render/cell_lines.h"
#include "render/colormap.h"
#include "store/series.h"

namespace mds::render {

struct SeriesLook {
  Bounds bounds;                 // union of the frames' centre bounds; radius_max the largest radius
  bool has_property = false;     // every frame has the property
  bool has_color = false;        // every frame has per-particle colours (--color-by auto draws them then)
  bool has_cell = false;         // every frame has a simulation cell (--cell auto draws them then)
  double property_min = 0.0, property_max = 0.0;  // union of the frames' property ranges
};

// Reads the headers of the stores at `frames` (indices into series.frames, non-empty; each
// < series.frames.size()); errors name the series frame and its store.
Result<SeriesLook> series_look(const store::Series& series, std::span<const int64_t> frames);

// --color-by auto over a series: the particles' own colours only when every frame has them
// (look.has_color), so that the frames do not switch between colours and types; `c` unchanged
// for any other choice.
ColorBy series_color_by(const ColorBy& c, const SeriesLook& look);

// --cell over a series: auto draws the frames' cells only when every frame has one
// (look.has_cell), so that the cell does not come and go; on without that is
// Errc::invalid_argument naming `series` (before any frame is drawn); off stays off.
Result<CellMode> series_cell_mode(CellMode mode, const SeriesLook& look, const std::string& series);

// The range `c` colours over in every frame: c's own range when it has one (lo < hi), else the
// look's bounds along c's axis or its property range (property_default_range). By type: (0, 0).
glm::dvec2 series_color_range(const ColorBy& c, const SeriesLook& look);

}  // namespace mds::render
