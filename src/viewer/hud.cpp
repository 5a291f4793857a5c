#include "viewer/hud.h"

#include <algorithm>

#include <fmt/format.h>

namespace mds::viewer {

std::vector<std::string> hud_lines(const HudState& s) {
  std::vector<std::string> l;
  const auto& r = s.report;
  l.push_back(fmt::format("{}  {}{}{}", s.store_name, s.streaming ? "streaming" : "in memory",
                          s.playing ? "  [play]" : "", s.recording ? "  [rec]" : ""));
  l.push_back(fmt::format("frame {:.1f} ms ({:.0f} fps)  step {:.1f} ms  gpu {:.1f} ms", s.frame_ms,
                          s.frame_ms > 0 ? 1000.0 / s.frame_ms : 0.0, s.step_ms, r.gpu_ms));
  const char* state = s.idle ? "converged (idle)"
                      : r.converged ? "converged, accumulating"
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
    l.push_back(fmt::format("cache {:.1f}/{:.1f} MB ({:.0f}%)  nodes {}/{}  in flight {}", c.resident_bytes / 1e6,
                            c.gpu_budget_bytes / 1e6,
                            c.gpu_budget_bytes ? 100.0 * double(c.resident_bytes) / double(c.gpu_budget_bytes) : 0.0,
                            c.nodes_resident, c.nodes, c.in_flight));
    l.push_back(fmt::format("read {:.1f} MB/s  total {:.1f} MB  hits {}  misses {}{}", s.read_mb_s, c.bytes_read / 1e6,
                            r.frame_hits, r.frame_misses, c.budget_exhausted ? "  BUDGET FULL" : ""));
  }
  l.push_back(fmt::format("{} fov {:.0f}  view: {}", s.ortho ? "ortho" : "persp", s.fov_y_deg, s.view_name));
  if (!s.message.empty()) l.push_back(s.message);
  return l;
}

void draw_hud(Canvas& canvas, const HudState& s) {
  const auto lines = hud_lines(s);
  const int scale = canvas.width() >= 800 ? 2 : 1;
  const int line_h = 10 * scale;
  int w = 0;
  for (const auto& t : lines) w = std::max(w, Canvas::text_size(t, scale).x);
  canvas.fill_rect(0, 0, w + 8 * scale, int(lines.size()) * line_h + 4 * scale, {0, 0, 0, 150});
  int y = 3 * scale;
  for (const auto& t : lines) {
    canvas.text(4 * scale, y, t, {235, 235, 235, 255}, scale);
    y += line_h;
  }
}

}  // namespace mds::viewer
