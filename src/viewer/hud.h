// Heads-up display of the viewer: a text block (stb_easy_font) over the top-left of the frame
// with frame time, samples, culling, convergence, cache residency and class counts, and a legend
// of the particle types' colours.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "render/renderer.h"
#include "store/format.h"
#include "overlay/canvas.h"
#include "overlay/color_legend.h"

namespace mds::viewer {

using overlay::Canvas;
using overlay::LegendEntry;
using overlay::Rgba8;

// The HUD's legend shows this many types at most, then "+N".
inline constexpr size_t kHudLegendMax = 12;

struct HudState {
  std::string store_name;
  bool streaming = false;
  bool cull = true;
  double c_occ = 0.0;
  std::string coverage;       // sample-area model: "auto" | "expected" | "exact" (key K)
  uint32_t spp = 0;
  bool ortho = false;
  double fov_y_deg = 0.0;
  double frame_ms = 0.0;      // wall time of the last displayed frame (loop iteration)
  double step_ms = 0.0;       // renderer step() wall time
  double gpu_ms = 0.0;
  bool idle = false;          // converged and accumulated: not stepping
  bool playing = false;
  bool recording = false;
  double read_mb_s = 0.0;     // compressed bytes read from the store per second (recent)
  std::string view_name;
  double ao_radius = 0.0;     // ambient occlusion radius (key L; 0: off)
  std::string series;         // a series' frame line ("series frame K (i/n)  time T"); empty: not a series
  std::string threshold;      // "threshold c_pe -6:" (--threshold); empty: none
  std::string message;        // transient status line (screenshot saved, errors)
  std::string pick;           // the picked particle (right click) while it is marked; empty: none
  render::FrameReport report;
  render::CacheStats cache;
  uint64_t meshlets = 0;
  // Dynamic resolution (render/frame_pacer.h): the render size of the image shown and the
  // controller's target (0: automatic target not known yet).
  bool dynamic_resolution = false;
  uint32_t render_width = 0, render_height = 0;
  double render_scale = 1.0;
  double frame_ms_target = 0.0;
  // overlay::type_legend (one per particle type, in type order) or overlay::colormap_legend;
  // empty: no legend row.
  std::vector<LegendEntry> legend;
};

std::vector<std::string> hud_lines(const HudState& s);
// Draws the lines, then the legend row (a swatch and a label per type), over a translucent box
// at the top-left; scale 1 below 800 px width, else 2.
void draw_hud(Canvas& canvas, const HudState& s);

}  // namespace mds::viewer
