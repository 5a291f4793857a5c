// Node payload codec (format.h, "Decoded node payload layout"; docs/store-format.md, "Node
// payload"): per-meshlet offset bit-packing of quantized positions and type indices, before
// LZ4. The encoder and the validating decoder are shared by the writer, the reader and the tests.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"
#include "store/format.h"
#include "store/store_reader.h"
#include "store/store_writer.h"

namespace mds::store {

// Serializes a node whose arrays encode_node has already checked (sizes, meshlet sums) into
// the decoded payload layout; `raw` is resized. Deterministic.
void encode_payload(const NodeInput& node, std::vector<uint8_t>& raw);

struct PayloadLimits {
  uint32_t particle_count;     // n of the node
  uint32_t meshlet_count;      // m of the node
  uint32_t flags;              // the header's: kFlagPerParticleRadius, kFlagProperty, kFlagColor
  uint32_t type_count;         // type indices must be < this
  uint32_t meshlet_size_max;   // meshlet sizes must be in 1..this
};

// Decodes and validates a decoded (LZ4-expanded) payload. Treats `raw` as hostile: every size,
// width, base + offset and type index is checked before use. Errors (Errc::range / format)
// carry a message without the file prefix, e.g. "meshlet 3 has 0 particles (allowed 1..16)".
Status decode_payload_raw(std::span<const uint8_t> raw, const PayloadLimits& limits, NodeData& out);

}  // namespace mds::store
