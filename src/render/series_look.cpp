// Fixed camera bounds and colour range over a store series; see series_look.h.
#include "render/series_look.h"

#include <algorithm>

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
    const bool per_particle = (h.flags & store::kFlagPerParticleRadius) != 0;  // as render::begin_scene
    double rmax = per_particle ? h.radius_max : 0.0;
    if (!per_particle)
      for (const store::TypeEntry& t : (*r)->types()) rmax = std::max(rmax, double(t.radius));
    const bool prop = (h.flags & store::kFlagProperty) != 0;
    for (int d = 0; d < 3; ++d) {
      look.bounds.min[d] = first ? h.bounds_min[d] : std::min(look.bounds.min[d], h.bounds_min[d]);
      look.bounds.max[d] = first ? h.bounds_max[d] : std::max(look.bounds.max[d], h.bounds_max[d]);
    }
    look.bounds.radius_max = first ? rmax : std::max(look.bounds.radius_max, rmax);
    look.property_min = first ? h.property_min : std::min(look.property_min, double(h.property_min));
    look.property_max = first ? h.property_max : std::max(look.property_max, double(h.property_max));
    look.has_property = first ? prop : look.has_property && prop;
    first = false;
  }
  return look;
}

glm::dvec2 series_color_range(const ColorBy& c, const SeriesLook& look) {
  if (c.by_type()) return glm::dvec2(0.0);
  if (c.lo < c.hi) return glm::dvec2(c.lo, c.hi);
  if (c.by_property()) return property_default_range(look.property_min, look.property_max);
  return glm::dvec2(look.bounds.min[c.axis], look.bounds.max[c.axis]);
}

}  // namespace mds::render
