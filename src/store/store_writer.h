// Writing a store: nodes are encoded (LZ4 + XXH3) independently, possibly on worker
// threads, then appended in order by one writer that owns the temporary output file.
// The file appears at its final path only after finish() succeeded (write to
// "<path>.tmp.<pid>", fsync, rename); a writer destroyed before finish() removes it.
#pragma once

#include <array>
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

// One node's decoded content, in meshlet order. Preconditions: qpos.size() == 3n,
// type_index.size() == n, radius_q.size(), property_q.size() and color.size() are n or 0, sum(meshlet_size)
// == n, 1 <= n <= 65535.
struct NodeInput {
  std::span<const uint16_t> qpos;
  std::span<const uint8_t> type_index;
  std::span<const uint16_t> radius_q;
  std::span<const uint16_t> property_q;  // the per-particle scalar, quantized (format.h kFlagProperty)
  std::span<const uint32_t> color;       // per-particle RGBA8, R in bits 0-7 (format.h kFlagColor)
  std::span<const uint8_t> meshlet_size;
  double center_min[3];
  double center_max[3];
  float max_radius;
  std::span<const VoxelRef> voxels;  // sorted by voxel index, counts > 0, sum == n
};

// A node ready to append: compressed payload plus the directory fields known so far.
struct EncodedNode {
  std::vector<uint8_t> payload;  // LZ4 block
  NodeEntry entry;               // offsets/prefix sums/voxel_first filled in by append()
  std::vector<VoxelRef> voxels;
  std::array<uint8_t, kOccupancyBytes> occupancy{};  // the node's occupancy record (format.h)
  PropertyHistogram property_histogram{};             // with a property: its histogram (format.h)
  // Filled by encode_node; the writer uses them to fill TypeEntry::particle_count and to
  // check the node against the build parameters in finish().
  std::vector<uint64_t> type_counts;  // particles per type index (size = largest index + 1)
  uint32_t max_meshlet_size = 0;
  bool per_particle_radius = false;  // the payload carries radius_q
  bool property = false;             // the payload carries property_q
  bool color = false;                // the payload carries color
};

// Pure and thread-safe: serializes and compresses one node.
Result<EncodedNode> encode_node(const NodeInput& node);

struct StoreSummary {
  uint32_t flags = 0;
  uint32_t node_size_max = 0;
  uint32_t meshlet_size_max = 0;
  double bounds_min[3] = {0, 0, 0};
  double bounds_max[3] = {0, 0, 0};
  float radius_min = 0;
  float radius_max = 0;
  std::string property_name;  // with kFlagProperty: 1..47 bytes
  float property_min = 0;     // with kFlagProperty: the range property_q maps to
  float property_max = 0;
  double max_quantization_error = 0;
  double max_error_over_half_step = 0;
  std::vector<TypeEntry> types;
  // Density grid: dims and the world box it covers; counts has dims[0]*dims[1]*dims[2] entries
  // (at most 2^28). dims {0,0,0} means "no density grid": then nodes carry no VoxelRefs.
  uint32_t density_dims[3] = {0, 0, 0};
  double density_min[3] = {0, 0, 0};
  double density_max[3] = {0, 0, 0};
  std::vector<uint32_t> density_counts;
  // The simulation cell, written as the cell section (kFlagCell, set by finish(): `flags` need
  // not carry it); finite.
  std::optional<SimulationCell> cell;
};

class StoreWriter {
 public:
  // Creates the temporary file next to `path`. Fails if the directory is not writable.
  static Result<std::unique_ptr<StoreWriter>> create(const std::filesystem::path& path);
  ~StoreWriter();
  StoreWriter(const StoreWriter&) = delete;
  StoreWriter& operator=(const StoreWriter&) = delete;

  // Capacity hint for the tables kept until finish() (directory entries, voxel refs, occupancy
  // records), so that appends do not copy them as they grow (2.7 % of a 10M conversion's CPU
  // time in a profile, with their page faults). Reserved as address space: an overestimate
  // maps no memory until written. Optional; any count may be exceeded.
  void reserve(uint64_t nodes, uint64_t voxel_refs);
  // Appends the next node (nodes are numbered in append order).
  Status append(EncodedNode&& node);
  // Writes sections and header, fsyncs and renames to the final path. The header counts,
  // payload sums and TypeEntry::particle_count are computed from the appended nodes
  // (summary.types[i].particle_count is ignored). Checks every node against the summary
  // (type indices < types.size(), node/meshlet sizes <= the build parameters, radius flag)
  // and the density volume against the voxel lists (density[v] == sum of VoxelRef counts).
  Status finish(const StoreSummary& summary);

  uint64_t bytes_written() const;
  uint64_t node_count() const;

 private:
  StoreWriter() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mds::store
