// Fixed camera bounds and colour range over a store series; see series_look.h.
#include "render/series_look.h"

#include <algorithm>

#include "render/scene.h"
#include "store/store_reader.h"

namespace mds::render {

Result<SeriesLook> series_look(const store::Series& series, std::span<const int64_t> frames) {
  SeriesLook look;
  bool first = true;
  for (int64_t k : frames) {
    const store::SeriesFrame& f = series.frames.at(size_t(k));
    auto r = store::StoreReader::open(f.path);
    if (!r.ok()) {
      Error e = r.error();
      e.message = fmt::format("{}: frame {} ({}): {}", series.file.string(), k, f.name, e.message);
      return e;
    }
    const store::FileHeader& h = (*r)->header();
    std::vector<float> radii;
    for (const store::TypeEntry& t : (*r)->types()) radii.push_back(t.radius);
    // The frame's bounds as its scene has them (render::begin_scene: centres, largest radius).
    const Bounds b = begin_scene({h.bounds_min[0], h.bounds_min[1], h.bounds_min[2]},
                                 {h.bounds_max[0], h.bounds_max[1], h.bounds_max[2]}, radii,
                                 (h.flags & store::kFlagPerParticleRadius) != 0, h.radius_min, h.radius_max)
                         .bounds;
    const bool prop = (h.flags & store::kFlagProperty) != 0;
    look.bounds.min = first ? b.min : glm::min(look.bounds.min, b.min);
    look.bounds.max = first ? b.max : glm::max(look.bounds.max, b.max);
    look.bounds.radius_max = first ? b.radius_max : std::max(look.bounds.radius_max, b.radius_max);
    look.property_min = first ? h.property_min : std::min(look.property_min, double(h.property_min));
    look.property_max = first ? h.property_max : std::max(look.property_max, double(h.property_max));
    look.has_property = first ? prop : look.has_property && prop;
    const bool color = (h.flags & store::kFlagColor) != 0;
    look.has_color = first ? color : look.has_color && color;
    const bool cell = (h.flags & store::kFlagCell) != 0;
    look.has_cell = first ? cell : look.has_cell && cell;
    first = false;
  }
  return look;
}

ColorBy series_color_by(const ColorBy& c, const SeriesLook& look) {
  ColorBy r = c;
  if (c.axis == kColorByAuto) r.axis = look.has_color ? kColorByColor : -1;
  return r;
}

Result<CellMode> series_cell_mode(CellMode mode, const SeriesLook& look, const std::string& series) {
  if (mode == CellMode::on && !look.has_cell)
    return make_error(Errc::invalid_argument, "--cell on: not every picked frame of {} has a simulation cell", series);
  if (mode == CellMode::automatic) return look.has_cell ? CellMode::on : CellMode::off;
  return mode;
}

glm::dvec2 series_color_range(const ColorBy& c, const SeriesLook& look) {
  if (c.by_type()) return glm::dvec2(0.0);
  if (c.lo < c.hi) return glm::dvec2(c.lo, c.hi);
  if (c.by_property()) return property_default_range(look.property_min, look.property_max);
  return glm::dvec2(look.bounds.min[c.axis], look.bounds.max[c.axis]);
}

}  // namespace mds::render
