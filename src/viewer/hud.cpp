#include "viewer/hud.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "render/scene.h"

namespace mds::viewer {

std::vector<std::string> hud_lines(const HudState& s) {
  std::vector<std::string> l;
  const auto& r = s.report;
  l.push_back(fmt::format("{}  {}{}{}", s.store_name, s.streaming ? "streaming" : "in memory",
                          s.playing ? "  [play]" : "", s.recording ? "  [rec]" : ""));
  if (!s.series.empty()) l.push_back(s.series);
  if (!s.threshold.empty()) l.push_back(s.threshold);
  l.push_back(fmt::format("frame {:.1f} ms ({:.0f} fps)  step {:.1f} ms  gpu {:.1f} ms", s.frame_ms,
                          s.frame_ms > 0 ? 1000.0 / s.frame_ms : 0.0, s.step_ms, r.gpu_ms));
  const char* state = s.idle ? (r.converged ? "converged (idle)" : "culling capped (idle)")
                      : r.converged ? "converged, accumulating"
                      : r.settled ? "culling capped (--max-iterations), accumulating"
                      : r.culling_active ? "culling"
                      : (s.streaming && !r.complete) ? "loading"
                                                     : "refining";
  l.push_back(fmt::format("samples {}/{}  {}", r.samples, s.spp, state));
  if (s.dynamic_resolution)
    l.push_back(fmt::format("render {}x{}  scale {:.2f}  target {}", s.render_width, s.render_height, s.render_scale,
                            s.frame_ms_target > 0.0 ? fmt::format("{:.0f} ms", s.frame_ms_target) : std::string("auto")));
  else
    l.push_back(fmt::format("render {}x{}  fixed resolution", s.render_width, s.render_height));
  const uint64_t total = uint64_t(r.class_counts[0]) + r.class_counts[1] + r.class_counts[2] + r.class_counts[3];
  if (s.cull)
    l.push_back(fmt::format("culled {:.1f}% of {} meshlets  C_occ {:.3f}  coverage {}",
                            total ? 100.0 * r.class_counts[3] / double(total) : 0.0, total, s.c_occ, s.coverage));
  else
    l.push_back("culling off (C toggles)");
  l.push_back(fmt::format("meshlets P {} L {} M {} O {}", r.class_counts[0], r.class_counts[1], r.class_counts[2],
                          r.class_counts[3]));
  l.push_back(fmt::format("nodes    P {} L {} M {} O {}", r.node_class_counts[0], r.node_class_counts[1],
                          r.node_class_counts[2], r.node_class_counts[3]));
  if (s.streaming) {
    const auto& c = s.cache;
    l.push_back(fmt::format("cache {:.1f}/{:.1f} MB ({:.0f}%)  nodes {}/{}  in flight {}{}{}", c.resident_bytes / 1e6,
                            c.gpu_budget_bytes / 1e6,
                            c.gpu_budget_bytes ? 100.0 * double(c.resident_bytes) / double(c.gpu_budget_bytes) : 0.0,
                            c.nodes_resident, c.nodes, c.in_flight,
                            c.nodes_left_out ? fmt::format("  left out {}", c.nodes_left_out) : std::string(),
                            // a series step: the first wave carried from the frame before (docs/streaming.md)
                            c.carried_nodes ? fmt::format("  carried {}", c.carried_nodes) : std::string()));
    l.push_back(fmt::format("read {:.1f} MB/s  total {:.1f} MB  hits {}  misses {}{}", s.read_mb_s, c.bytes_read / 1e6,
                            r.frame_hits, r.frame_misses, c.budget_exhausted ? "  BUDGET FULL" : ""));
  }
  l.push_back(fmt::format("{} fov {:.0f}  view: {}{}", s.ortho ? "ortho" : "persp", s.fov_y_deg, s.view_name,
                          s.ao_radius > 0.0 ? fmt::format("  ao r {:g}", s.ao_radius) : std::string()));
  if (!s.pick.empty() && s.pick != s.message) l.push_back(s.pick);  // stays while the message fades
  if (!s.message.empty()) l.push_back(s.message);
  return l;
}

void draw_hud(Canvas& canvas, const HudState& s) {
  const auto lines = hud_lines(s);
  const int scale = canvas.width() >= 800 ? 2 : 1;
  const int line_h = 10 * scale;
  const Rgba8 text_color = overlay::kPanelText;
  // The legend row: per type a swatch of the text's height, a gap, the label, a wider gap.
  const int swatch = 7 * scale, gap = 3 * scale, sep = 8 * scale;
  const size_t shown = std::min(s.legend.size(), kHudLegendMax);
  const std::string more = s.legend.size() > shown ? fmt::format("+{}", s.legend.size() - shown) : std::string();
  int legend_w = 0;
  for (size_t i = 0; i < shown; ++i) legend_w += swatch + gap + Canvas::text_size(s.legend[i].label, scale).x + sep;
  if (!more.empty()) legend_w += Canvas::text_size(more, scale).x;
  int w = legend_w;
  for (const auto& t : lines) w = std::max(w, Canvas::text_size(t, scale).x);
  const int rows = int(lines.size()) + (shown > 0 ? 1 : 0);
  canvas.fill_rect(0, 0, w + 8 * scale, rows * line_h + 4 * scale, overlay::kPanelFill);
  int y = 3 * scale;
  for (const auto& t : lines) {
    canvas.text(4 * scale, y, t, text_color, scale);
    y += line_h;
  }
  int x = 4 * scale;
  for (size_t i = 0; i < shown; ++i) {
    canvas.fill_rect(x, y, x + swatch, y + swatch, s.legend[i].color);
    x += swatch + gap;
    x += canvas.text(x, y, s.legend[i].label, text_color, scale).x + sep;
  }
  if (!more.empty()) canvas.text(x, y, more, text_color, scale);
}

}  // namespace mds::viewer
