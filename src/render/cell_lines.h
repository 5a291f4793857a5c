// The simulation cell drawn with the particles (docs/rendering.md, "Simulation cell"): its twelve
// edges as lines a few pixels wide, depth tested against the spheres, as OVITO draws the cell and
// ParaView an outline. The store keeps the cell (store kFlagCell, core/cell.h); `--cell` chooses
// whether it is drawn. The GPU side is cell_lines.vert / cell_lines.frag, fed by the frame
// uniforms this file fills (FrameUniforms::cell).
#pragma once

#include <optional>
#include <string_view>

#include <glm/glm.hpp>

#include "core/cell.h"
#include "core/result.h"
#include "render/camera.h"
#include "store/store_reader.h"

namespace mds::render {

enum class CellMode { off, on, automatic };

// "off", "on" or "auto"; Errc::invalid_argument quoting the text otherwise.
Result<CellMode> parse_cell_mode(std::string_view text);

// The cell to draw: none when off, the store's when it has one (auto, on), and for `on` without
// one Errc::invalid_argument naming the store.
Result<std::optional<SimulationCell>> resolve_cell(CellMode mode, const store::StoreReader& reader);

// FrameUniforms::cell (gpu_types.h) of `cell` in a scene whose float coordinates are relative to
// `origin`: [0] origin - scene origin with w = 1 (drawn), [1..3] the vectors, [4] the colour made
// linear and the width in pixels. Without a cell all zero (w 0: not drawn).
// `bounds` grown to hold the cell's corners (the clip planes of a view that draws the cell:
// fit_clip_planes); `bounds` itself without one.
Bounds with_cell(const Bounds& bounds, const std::optional<SimulationCell>& cell);

void cell_uniforms(const std::optional<SimulationCell>& cell, const glm::dvec3& origin, const glm::vec3& color_srgb,
                   float width_px, glm::vec4 out[5]);

}  // namespace mds::render
