// Meshlets (paper 000, §3.1 and §6 "Meshlet generation"): small groups of spatially close
// particles inside a node. Two builders, chosen with `--meshlet-builder`:
//   pcl     PCL kd-tree neighbourhoods (the default, as issue 2 specifies). Greedy: the first
//           unassigned particle in Morton order seeds a meshlet; its k nearest neighbours fill
//           it with the nearest unassigned particles. For speed the node is cut into Morton runs
//           of about kPclChunk particles (rounded to a multiple of the meshlet size), and one
//           small kd-tree is built per run, once: O(n log C) instead of O(n log n), at a small
//           loss of compactness (measured below). When too few of the k nearest are free, and
//           for the last kPclScanMeshlets meshlets of a run, the nearest free particles come
//           from an exact scan of the run's unassigned ones (the same meshlet a wider query or
//           a tree rebuilt over the unassigned ones gives, much cheaper): the scan walks a list
//           of the free particles that drops assigned ones as it goes and keeps the nearest in
//           a small sorted array, so it costs what is left of the run.
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

// Particles (Morton runs) per kd-tree of the PCL builder. Measured on porous (2M particles,
// meshlet size 16): whole node (10000) 730 ns/particle, diag/spacing 4.18; 512: 440 ns, 4.57;
// 256: 370 ns, 4.73; 128: 290 ns, 4.91; 64: 220 ns, 5.05.
// (Those figures are from the earlier builder that rebuilt the tree over the unassigned particles;
// the exact scan gives the same meshlets: 10M porous, meshlet CPU 3.7 s -> 2.6 s,
// same diag/spacing 4.78 and mean size 15.98.)
inline constexpr uint32_t kPclChunk = 256;
// Meshlets at the end of each run filled by the exact scan without a kd-tree query. Any value
// gives the same meshlets (the kd-tree answer and the exact scan agree); only the cost differs.
// Meshlet CPU seconds, porous 2M particles, one thread, runs of 256 (16 meshlets), k = 32:
//   4: 0.54   8: 0.44   12: 0.39   16 (no kd-tree at all): 0.19
// With the kd-tree queried directly (meshlet_pcl.cpp, PclKdTree), porous 4M raw, meshlet CPU
// seconds over both workers, 3 runs each: 2: 0.98-1.01  4: 0.92-0.96  8: 0.75-0.83  16: 0.37-0.38.
// With the cheap scan a query is not faster than a scan even early in a run; the kd-tree still
// answers the first half of each run's meshlets, as issue 2 asks for PCL neighbourhoods.
inline constexpr uint32_t kPclScanMeshlets = 8;

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
