// The build stage of the converter for one sorted bin (paper 000, §3.1, §4.4, §6, §7.4;
// paper 002, §3.3): nodes from the shared octree partition (node_builder.h), then on worker
// threads per node: gather the node's records through the sort permutation, meshlets
// (meshlet_builder.h), meshlet quality, 16-bit quantization (quantize.h), density voxel lists
// (density.h) and store::encode_node; the calling thread appends the nodes in order while at
// most kWindowPerThread encoded nodes per worker wait.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "convert/density.h"
#include "convert/meshlet_builder.h"
#include "convert/meshlet_quality.h"
#include "convert/morton.h"
#include "convert/progress.h"
#include "convert/quantize.h"
#include "convert/record_view.h"
#include "convert/spill.h"
#include "core/result.h"
#include "store/store_writer.h"

namespace mds::convert {

inline constexpr unsigned kWindowPerThread = 4;  // encoded nodes in flight per worker

// Input type id -> uint8 type index.
class TypeLut {
 public:
  explicit TypeLut(const std::vector<int32_t>& sorted_ids);
  uint8_t operator()(int32_t id) const;

 private:
  int64_t lo_ = 0;
  std::vector<uint8_t> dense_;
  std::vector<std::pair<int32_t, uint8_t>> sparse_;  // sorted by id
};

struct BuildContext {
  uint32_t node_size = 0;
  uint32_t meshlet_size = 0;
  MeshletBuilderKind meshlet_builder = MeshletBuilderKind::pcl;
  DensityGrid density;
  const TypeLut* lut = nullptr;
  std::vector<float> type_radius;  // by type index
  bool per_particle_radius = false;
  float radius_min = 0, radius_max = 0;
  // The records' side column (SpillRecords::side): the property, quantized into [property_min,
  // property_max], and the colour.
  SideLayout side;
  float property_min = 0, property_max = 0;
};

struct BuildTotals {
  uint64_t nodes = 0, meshlets = 0, particles = 0;
  uint64_t payload_bytes = 0, payload_raw_bytes = 0;
  QuantError error;
  MeshletQuality quality;
  double t_gather = 0, t_meshlets = 0, t_encode = 0, t_append = 0;  // CPU seconds
  std::vector<uint32_t> density;
};

// Per-worker scratch, reused across nodes and bins.
struct NodeWorker {
  explicit NodeWorker(std::unique_ptr<MeshletBuilder> builder) : meshlets(std::move(builder)) {}
  std::unique_ptr<MeshletBuilder> meshlets;
  std::vector<double> xyz;
  std::vector<uint32_t> order;
  std::vector<uint8_t> sizes;
  std::vector<uint16_t> qpos;
  std::vector<uint8_t> type_index;
  std::vector<uint16_t> radius_q;
  std::vector<uint16_t> property_q;
  std::vector<uint32_t> color;          // RGBA8 per particle (BuildContext::side.color)
  std::vector<uint32_t> color_scratch;  // the colours' permutation
  std::vector<uint32_t> vcoords;  // density voxel coordinates, 3 per particle
  std::vector<store::VoxelRef> refs;
  std::vector<uint32_t> voxel_scratch;
  std::vector<uint16_t> permute_scratch;
  std::vector<uint64_t> keys;  // the node's Morton keys, where the source has no key array
};

// Builds and appends the nodes of one bin: `keys` sorted, `perm[i]` the record of keys[i],
// all keys inside the octree cell of depth `start_level`. With ctx.side's columns, recs.side
// holds ctx.side.words() per record.
Status build_bin(const BuildContext& ctx, std::vector<std::unique_ptr<NodeWorker>>& workers,
                 std::span<const uint64_t> keys, std::span<const uint32_t> perm, const SpillRecords& recs,
                 int start_level, store::StoreWriter& writer, BuildTotals& tot, Progress& progress);
// The same over the raw positions sorted by their keys in `grid` (xyz_sort.h; identity
// permutation). The keys are computed where needed (nodes, meshlets), not read from an array.
Status build_bin(const BuildContext& ctx, std::vector<std::unique_ptr<NodeWorker>>& workers,
                 const SortedXyzRecords& recs, const MortonGrid& grid, int start_level, store::StoreWriter& writer,
                 BuildTotals& tot, Progress& progress);

// CPU time of the calling thread.
double thread_cpu_seconds();

}  // namespace mds::convert
