// Meshlets (paper 000, §3.1 and §6 "Meshlet generation"): small groups of spatially close
// particles built with the Point Cloud Library's kd-tree neighbourhoods. Greedy: the first
// unassigned particle in Morton order seeds a meshlet; its k nearest neighbours
// (k = 2 x meshlet size) fill the meshlet with the nearest unassigned particles. When too
// few are free, the kd-tree is rebuilt over the unassigned particles (once half of its
// points are taken) or the query widened. Every particle lands in exactly one meshlet.
//
// This is the only place that includes PCL; the builder keeps its point cloud and kd-tree
// between calls so that one builder per worker thread avoids allocation churn.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/result.h"

namespace mds::convert {

class MeshletBuilder {
 public:
  MeshletBuilder();
  ~MeshletBuilder();
  MeshletBuilder(const MeshletBuilder&) = delete;
  MeshletBuilder& operator=(const MeshletBuilder&) = delete;

  // xyz: n positions, interleaved (3n doubles), in Morton order; 1 <= meshlet_size <= 255.
  // On return, `order` holds the n particle indices in meshlet order and `sizes` the meshlet
  // sizes (sum == n, each 1..meshlet_size).
  Status build(std::span<const double> xyz, uint32_t meshlet_size, std::vector<uint32_t>& order,
               std::vector<uint8_t>& sizes);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mds::convert
