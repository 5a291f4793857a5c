#include "cli/vulkan/node_log.h"

#include <vector>

#include <fmt/format.h>

#include "core/text_file.h"
#include "render/culling/cull_loop.h"
#include "streaming/residency.h"

namespace mds::cli {

Status write_node_log(const std::string& path, const store::StoreReader& reader, render::Renderer& renderer,
                      std::span<const uint8_t> visible_nodes) {
  const auto& nodes = reader.nodes();
  const std::vector<render::NodeLogEntry> log = renderer.node_log();
  std::span<const uint32_t> classes;
  if (log.empty() && renderer.cull_loop()) classes = renderer.cull_loop()->node_classes();
  std::string csv =
      "node,particles,payload_bytes,class,visible,carried,requests,reads,first_request_frame,loaded,resident,"
      "in_frustum,wanted\n";
  for (size_t i = 0; i < nodes.size(); ++i) {
    std::string cls, vis;
    if (i < log.size()) cls = streaming::class_letter(log[i].cls);
    else if (i < classes.size()) cls = streaming::class_letter(uint8_t(classes[i]));
    if (i < visible_nodes.size()) vis = visible_nodes[i] ? "1" : "0";
    csv += fmt::format("{},{},{},{},{}", i, nodes[i].particle_count, nodes[i].payload_bytes, cls, vis);
    if (i < log.size()) {
      const render::NodeLogEntry& e = log[i];
      csv += fmt::format(",{:d},{},{},{},{:d},{:d},{:d},{:d}\n", e.carried, e.requests, e.reads, e.first_request_frame,
                         e.loaded, e.resident, e.in_frustum, e.wanted);
    } else {
      csv += ",,,,,,,,\n";
    }
  }
  return write_text_atomically(path, csv);
}

}  // namespace mds::cli
