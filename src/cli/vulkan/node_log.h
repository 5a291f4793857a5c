// --node-log of `render` and `stress` (docs/streaming.md, "Node log"): one CSV row per node of
// the store after the last frame -- its particles, payload bytes, class and whether it holds a
// visible particle, and, streaming, what the cache did with it (Renderer::node_log).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "core/result.h"
#include "render/renderer.h"
#include "store/store_reader.h"

namespace mds::cli {

// Columns: node, particles, payload_bytes, class (P/L/M/O: the cache's when streaming, by the
// frustum alone with --no-cull; the culling loop's in memory, empty there without culling),
// visible (visible_nodes[node], empty when visible_nodes is empty), then carried, requests,
// reads, first_request_frame, loaded, resident, in_frustum, wanted (streaming; empty in memory).
// Written atomically (temporary file + rename).
Status write_node_log(const std::string& path, const store::StoreReader& reader, render::Renderer& renderer,
                      std::span<const uint8_t> visible_nodes);

}  // namespace mds::cli
