// The `octree` meshlet builder: meshlets are the leaves of the implicit octree over the node's
// sorted Morton keys with capacity meshlet size (paper 000, §6 "Meshlet generation", with the
// node's own octree partition, octree_partition.h, applied at meshlet scale). O(n).
#pragma once

#include "convert/meshlet_builder.h"
#include "convert/octree_partition.h"

namespace mds::convert {

class OctreeMeshletBuilder final : public MeshletBuilder {
 protected:
  Status build_impl(std::span<const uint64_t> keys, std::span<const double> xyz, uint32_t meshlet_size,
                    std::vector<uint32_t>& order, std::vector<uint8_t>& sizes) override;

 private:
  std::vector<KeyRange> leaves_;
};

}  // namespace mds::convert
