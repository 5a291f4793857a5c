// Meshlet quality: how compact the meshlets of a builder are, so that the speed/quality
// trade-off between `--meshlet-builder pcl` and `octree` is visible (paper 000, §6: meshlets
// are culled by their bounding boxes, so smaller boxes at the same particle count cull better).
//   diag/spacing  the diagonal of a meshlet's bounding box of particle centres divided by the
//                 mean particle spacing of its node, (V / n)^(1/d) with V the node box volume
//                 over its d non-degenerate axes; averaged over meshlets. Scale-free: about 2.5
//                 for 16 particles in a compact cluster of a uniform lattice; larger is worse.
//   mean size     particles per meshlet (the capacity is --meshlet-size); smaller means more
//                 meshlets to cull and draw.
#pragma once

#include <cstdint>
#include <span>

namespace mds::convert {

struct MeshletQuality {
  double sum_diag_over_spacing = 0;  // over measured meshlets
  uint64_t measured = 0;             // meshlets of nodes with a non-zero spacing
  uint64_t meshlets = 0;
  uint64_t particles = 0;

  void merge(const MeshletQuality& o) {
    sum_diag_over_spacing += o.sum_diag_over_spacing;
    measured += o.measured;
    meshlets += o.meshlets;
    particles += o.particles;
  }
  double mean_diag_over_spacing() const { return measured ? sum_diag_over_spacing / double(measured) : 0.0; }
  double mean_size() const { return meshlets ? double(particles) / double(meshlets) : 0.0; }
};

// Mean particle spacing of n particles in the box [lo, hi]: (volume / n)^(1/d) over the d axes
// with a non-zero extent; 0 when all extents are 0 or n == 0.
double mean_spacing(const double lo[3], const double hi[3], uint64_t n);

// Adds one node's meshlets: xyz = the node's 3n positions, `order`/`sizes` as a meshlet
// builder returned them.
void add_meshlet_quality(std::span<const double> xyz, std::span<const uint32_t> order, std::span<const uint8_t> sizes,
                         MeshletQuality& q);
// The same with the node's bounding box of centres already known (saves a pass over xyz).
void add_meshlet_quality(std::span<const double> xyz, std::span<const uint32_t> order, std::span<const uint8_t> sizes,
                         const double node_lo[3], const double node_hi[3], MeshletQuality& q);

}  // namespace mds::convert
