#include "render/ambient_occlusion_setup.h"

#include <algorithm>

#include "render/culling/density_volume.h"

namespace mds::render {

Result<shading::AoMode> parse_ao_mode(const std::string& text) {
  if (text == "off") return shading::AoMode::off;
  if (text == "on") return shading::AoMode::on;
  if (text == "auto") return shading::AoMode::automatic;
  return make_error(Errc::invalid_argument, "--ao '{}': expected off, on or auto", text);
}

std::string ao_mode_name(shading::AoMode m) {
  return m == shading::AoMode::off ? "off" : m == shading::AoMode::on ? "on" : "auto";
}

Result<AoChoice> resolve_ao(const shading::AoSettings& settings, const store::StoreReader& reader) {
  AoChoice c;
  const store::FileHeader& h = reader.header();
  c.radius = settings.radius > 0.0 ? settings.radius
                                   : shading::kAoRadiusPerParticleRadius * std::max(double(h.radius_max), 0.0);
  if (settings.mode == shading::AoMode::automatic) {
    // The mean particle volume: the types' radii by their counts, or (per-particle radii) the
    // middle of the store's radius range.
    const bool per_particle = (h.flags & store::kFlagPerParticleRadius) != 0;
    double volume = 0.0, n = 0.0;
    for (const store::TypeEntry& t : reader.types()) {
      const double r = per_particle ? 0.5 * (double(h.radius_min) + double(h.radius_max)) : double(t.radius);
      volume += double(t.particle_count) * (4.0 / 3.0) * 3.141592653589793 * r * r * r;
      n += double(t.particle_count);
    }
    MDS_ASSIGN_OR_RETURN(const culling::DensityVolume grid, culling::density_from_store(reader, glm::dvec3(0.0)));
    c.packing = n > 0.0 ? shading::packing_fraction(grid.counts.data(), grid.counts.size(),
                                                    grid.cell.x * grid.cell.y * grid.cell.z, volume / n)
                        : 0.0;
    c.on = c.packing >= shading::kAoAutoPacking;
  } else {
    c.on = settings.mode == shading::AoMode::on;
  }
  c.on = c.on && c.radius > 0.0 && settings.strength > 0.0;
  c.strength = c.on ? settings.strength : 0.0;
  return c;
}

}  // namespace mds::render
