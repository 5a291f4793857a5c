// Reading a store. The file is treated as hostile: open() validates the header hash,
// every section's bounds and hash, and the consistency of the directory (counts, prefix
// sums, payload ranges inside the file and outside the sections) before anything is used.
// Payload reads are positioned (pread) and safe to call from several threads at once.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/cell.h"
#include "core/result.h"
#include "store/format.h"

namespace mds::store {

// A decoded node, caller-owned and reusable across decode_node() calls.
struct NodeData {
  std::vector<uint16_t> qpos;          // 3n
  std::vector<uint8_t> type_index;     // n
  std::vector<uint16_t> radius_q;      // n, or empty without kFlagPerParticleRadius
  std::vector<uint16_t> property_q;    // n, or empty without kFlagProperty
  std::vector<uint32_t> color;         // n RGBA8 (R in bits 0-7), or empty without kFlagColor
  std::vector<uint8_t> meshlet_size;   // m
  size_t particle_count() const { return type_index.size(); }
};

class StoreReader {
 public:
  // A path ending in .series (a store series index, store/series.h) is Errc::invalid_argument
  // naming its first store: a command that takes one store says so instead of "bad header".
  static Result<std::unique_ptr<StoreReader>> open(const std::filesystem::path& path);
  ~StoreReader();
  StoreReader(const StoreReader&) = delete;
  StoreReader& operator=(const StoreReader&) = delete;

  const std::filesystem::path& path() const;
  const FileHeader& header() const;
  uint64_t file_bytes() const;
  std::span<const TypeEntry> types() const;
  std::span<const NodeEntry> nodes() const;
  std::span<const VoxelRef> voxels(uint32_t node) const;  // this node's voxel list
  std::span<const uint32_t> density_counts() const;      // dims.x*dims.y*dims.z particle counts
  // The simulation cell (kFlagCell; docs/store-format.md, "Cell section"), or none.
  const std::optional<SimulationCell>& cell() const;
  // Per node, its property histogram (kFlagPropertyHistogram; store/property_histogram.h), each
  // checked against its node's particle count; empty for a store without them.
  std::span<const PropertyHistogram> property_histograms() const;
  // This node's occupancy record (kOccupancyBytes, format.h); empty for a node that does not exist.
  std::span<const uint8_t> occupancy(uint32_t node) const;

  // Reads node `i`'s compressed bytes into `out` (resized) and checks its hash.
  // Errc::checksum names the file, node index and byte offset on mismatch.
  Status read_payload(uint32_t i, std::vector<uint8_t>& out) const;
  // Decodes compressed bytes of node `i` (as read_payload gives them) into `out`,
  // validating sizes, meshlet sums and type indices.
  Status decode_payload(uint32_t i, std::span<const uint8_t> compressed, NodeData& out) const;
  // read_payload + decode_payload.
  Status read_node(uint32_t i, NodeData& out, std::vector<uint8_t>& scratch) const;
  // Checks that node `i`'s occupancy record holds every cell the decoded node `node` (from
  // decode_payload of the same node) reaches (docs/store-format.md, "Occupancy"): a record that
  // lacks one could make a renderer skip a visible node without reading it. Errc::format names
  // the node, the record's byte offset and the missing cell. Costs about as much as decoding.
  Status verify_occupancy(uint32_t i, const NodeData& node) const;
  // Checks that node `i`'s property histogram is the one of its decoded property values (a wrong
  // one could make a streaming renderer leave out a node a threshold keeps, unread). Errc::format
  // names the node, the record's byte offset and the first bin that differs. OK for a store
  // without histograms.
  Status verify_property_histogram(uint32_t i, const NodeData& node) const;

 private:
  StoreReader() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Quantization frame of a node: x = center_min + q * step.
inline double quant_step(const NodeEntry& e, int axis) {
  return (e.center_max[axis] - e.center_min[axis]) / double(kQuantMax);
}

}  // namespace mds::store
