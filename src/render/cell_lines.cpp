// The simulation cell drawn with the particles (see cell_lines.h).
#include "render/cell_lines.h"

#include <string>

#include "render/scene.h"

namespace mds::render {

Result<CellMode> parse_cell_mode(std::string_view text) {
  if (text == "off") return CellMode::off;
  if (text == "on") return CellMode::on;
  if (text == "auto") return CellMode::automatic;
  return make_error(Errc::invalid_argument, "'{}': expected off, on or auto", std::string(text.substr(0, 40)));
}

Result<std::optional<SimulationCell>> resolve_cell(CellMode mode, const store::StoreReader& reader) {
  if (mode == CellMode::off) return std::optional<SimulationCell>{};
  if (mode == CellMode::on && !reader.cell())
    return make_error(Errc::invalid_argument,
                      "--cell on: {} has no simulation cell (its input had no box: LAMMPS BOX BOUNDS, extended XYZ "
                      "Lattice, H5MD box/edges or an MMPLD bounding box)",
                      reader.path().string());
  return reader.cell();
}

Bounds with_cell(const Bounds& bounds, const std::optional<SimulationCell>& cell) {
  Bounds b = bounds;
  if (!cell) return b;
  for (int k = 0; k < 8; ++k) {
    const auto c = cell->corner(k);
    const glm::dvec3 p{c[0], c[1], c[2]};
    b.min = glm::min(b.min, p);
    b.max = glm::max(b.max, p);
  }
  return b;
}

void cell_uniforms(const std::optional<SimulationCell>& cell, const glm::dvec3& origin, const glm::vec3& color_srgb,
                   float width_px, glm::vec4 out[5]) {
  for (int i = 0; i < 5; ++i) out[i] = glm::vec4(0.0f);
  if (!cell) return;
  const glm::dvec3 o{cell->origin[0], cell->origin[1], cell->origin[2]};
  out[0] = glm::vec4(glm::vec3(o - origin), 1.0f);
  for (int v = 0; v < 3; ++v)
    out[1 + v] = glm::vec4(float(cell->vectors[v][0]), float(cell->vectors[v][1]), float(cell->vectors[v][2]), 0.0f);
  out[4] = glm::vec4(srgb_to_linear(color_srgb.r), srgb_to_linear(color_srgb.g), srgb_to_linear(color_srgb.b), width_px);
}

}  // namespace mds::render
