// Meshlets (paper 000, §3.1 and §6 "Meshlet generation"): small groups of spatially close
// particles inside a node. Two builders, chosen with `--meshlet-builder`:
//   pcl     PCL kd-tree neighbourhoods (the default, as issue 2 specifies) over the octree
//           leaves of capacity meshlet size (the `octree` builder's groups). The leaves, in
//           Morton order, seed the meshlets: a seed's free particles, then, from its
//           kPclNeighbourLeaves nearest leaves by centre (PCL's kd-tree over the leaf centres,
//           one per node), whole leaves that still fit, nearest first, then the free particles
//           of those leaves nearest to the seed, until the meshlet is full. A leaf taken whole
//           leaves no remnant behind; a remnant seeds its own meshlet when its turn comes.
//           About one kd-tree query per meshlet; nearly all meshlets are full.
//   octree  the leaves of the implicit octree over the node's sorted Morton keys with capacity
//           meshlet size: the same split + binary-halves merge as the nodes
//           (octree_partition.h), O(n), no geometry queries. Meshlets are octree boxes, but
//           their mean size is below the capacity.
// Every particle lands in exactly one meshlet with either builder. One builder per worker
// thread: each keeps its buffers (and the PCL one its point cloud and kd-tree) between nodes.
// Meshlet quality (meshlet_quality.h) makes the trade-off between the builders visible.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"

namespace mds::convert {

enum class MeshletBuilderKind { pcl, octree };

const char* meshlet_builder_name(MeshletBuilderKind kind);
std::optional<MeshletBuilderKind> parse_meshlet_builder(const std::string& name);

// Leaves asked of the kd-tree per meshlet of the PCL builder (widened 2x while they hold too few
// free particles). The seed's own leaf is usually the first answer (its centre is the seed's
// centre), so 3 brings two other leaves. Measured with tools/meshlet_bench (10M particles, meshlet
// size 16, one thread, builder time relative to k = 4 widened 4x; diag/spacing porous, ablation):
//   k = 4, 4x: 1.000, 4.095, 4.384   4, 2x: 0.955, 4.086, 4.377   3, 2x: 0.958, 4.065, 4.352
//   k = 2, 2x: 1.035, 4.026, 4.304   4, +2: 1.065, 4.087, -
// Fewer leaves give more compact meshlets (the top-up comes from the nearest leaves) and more
// widened queries; widening 2x instead of 4x makes those cheaper.
inline constexpr uint32_t kPclNeighbourLeaves = 3;

class MeshletBuilder {
 public:
  virtual ~MeshletBuilder() = default;
  // keys: n Morton keys, sorted ascending (global grid; the node's range of the sorted bin);
  // xyz: the n positions in the same order, interleaved (3n doubles); 1 <= meshlet_size <= 255.
  // On return, `order` holds the n particle indices in meshlet order and `sizes` the meshlet
  // sizes (sum == n, each 1..meshlet_size).
  Status build(std::span<const uint64_t> keys, std::span<const double> xyz, uint32_t meshlet_size,
               std::vector<uint32_t>& order, std::vector<uint8_t>& sizes);

 protected:
  // Called with validated arguments and n > meshlet_size; `order` and `sizes` are empty.
  virtual Status build_impl(std::span<const uint64_t> keys, std::span<const double> xyz, uint32_t meshlet_size,
                            std::vector<uint32_t>& order, std::vector<uint8_t>& sizes) = 0;
};

// The PCL builder comes from its module (meshlet_pcl_module.h): an error when it cannot be loaded.
Result<std::unique_ptr<MeshletBuilder>> make_meshlet_builder(MeshletBuilderKind kind);

}  // namespace mds::convert
