// `mdstream render --path`: one image per camera-path frame; see render_path.h.
#include "cli/vulkan/render_path.h"

#include <algorithm>
#include <cstdio>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/vulkan/stream_options.h"
#include "core/text_file.h"
#include "render/image_io.h"

namespace mds::cli {

Result<std::string> frame_file_name(const std::string& pattern, uint32_t frame, const char* option) {
  const auto bad = [&](const char* why) {
    return make_error(Errc::invalid_argument,
                      "{} '{}': {}; an animation (--path, or several frames of a series) writes one file per "
                      "frame, named by a %d or %04d in the name (frame_%04d.png)",
                      option, pattern, why);
  };
  std::string out;
  bool found = false;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') {
      out += pattern[i];
      continue;
    }
    if (found) return bad("more than one '%'");
    size_t j = i + 1;
    int width = 0;
    if (j < pattern.size() && pattern[j] == '0') {
      ++j;
      if (j >= pattern.size() || pattern[j] < '1' || pattern[j] > '9') return bad("expected %d or %0Nd (N 1..9)");
      width = pattern[j++] - '0';
    }
    if (j >= pattern.size() || pattern[j] != 'd') return bad("expected %d or %0Nd (N 1..9)");
    out += fmt::format("{:0{}}", frame, width);
    found = true;
    i = j;
  }
  if (!found) return bad("no %d in the name");
  return out;
}

Status render_path(render::Renderer& renderer, const render::CameraPath& path, const PathRenderOptions& o) {
  const uint32_t frames = path.frame_count();
  nlohmann::json rows = nlohmann::json::array();
  std::vector<double> wall;
  render::RenderStats last;
  for (uint32_t f = 0; f < frames; ++f) {
    MDS_ASSIGN_OR_RETURN(const std::string file, frame_file_name(o.output_pattern, f));
    render::RenderStats st;
    MDS_ASSIGN_OR_RETURN(render::FrameImage image, renderer.render(path.at(f), &st));
    for (const std::string& e : st.cache.errors) std::fprintf(stderr, "mdstream render: skipped node: %s\n", e.c_str());
    for (const std::string& w : cache_warnings(st.cache, o.max_storage_range))
      std::fprintf(stderr, "mdstream render: frame %u: warning: %s\n", f, w.c_str());
    overlay::ImagePanels panels = o.panels;
    panels.camera = path.at(f);
    if (!o.label_pattern.empty()) {
      overlay::LabelFields fields = o.label_fields;
      fields.frame = f;
      MDS_ASSIGN_OR_RETURN(panels.label, overlay::expand_label(o.label_pattern, fields));
    }
    overlay::overlay_panels(image, panels);
    MDS_TRY(render::write_image(file, image, o.transparent));
    const double culled = st.meshlets ? double(st.cull.meshlets_culled) / double(st.meshlets) : 0.0;
    std::string line = fmt::format("mdstream render: frame {}/{} -> {}: {:.0f} ms", f + 1, frames, file, st.wall_ms);
    if (st.cull.iterations > 0) line += fmt::format(", culled {:.1f} %", 100.0 * culled);
    if (o.streaming) line += fmt::format(", {:.2f} MB read so far", double(st.cache.bytes_read) / 1e6);
    std::fprintf(stderr, "%s\n", line.c_str());
    // GPU time per pass of the frame's render (median over its passes) and their sum, as the
    // stats of a single render give them (pass_ms_median, frame_ms_median).
    nlohmann::json r = {{"frame", f},
                        {"file", file},
                        {"wall_ms", st.wall_ms},
                        {"gpu_ms", st.frame_ms_median},
                        {"pass_ms_median", st.pass_ms_median}};
    if (!panels.label.empty()) r["label"] = panels.label;
    if (st.cull.iterations > 0) {
      r["culled_fraction"] = culled;
      r["culling_converged"] = st.cull.converged;
      r["culling_iterations"] = st.cull.iterations;
    }
    if (o.streaming) {
      r["bytes_read"] = st.cache.bytes_read;  // since the first frame: the cache stays between frames
      r["nodes_loaded"] = st.cache.nodes_loaded;
    }
    rows.push_back(r);
    wall.push_back(st.wall_ms);
    last = std::move(st);
  }
  if (!o.stats.empty()) {
    std::sort(wall.begin(), wall.end());
    nlohmann::json j;
    j["output_pattern"] = o.output_pattern;
    j["frames"] = frames;
    j["device"] = last.device;
    j["width"] = last.width;
    j["height"] = last.height;
    j["spp"] = last.spp;
    j["particles"] = last.particles;
    j["wall_ms_median"] = wall.empty() ? 0.0 : wall[wall.size() / 2];
    j["frame_stats"] = rows;
    MDS_TRY(write_text_atomically(o.stats, j.dump(2) + "\n"));
  }
  return {};
}

}  // namespace mds::cli
