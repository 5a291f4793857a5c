// The `pcl` meshlet builder: octree leaves filled from k-nearest-leaf neighbourhoods of the Point Cloud
// Library's kd-tree (paper 000, §6 "Meshlet generation"); see meshlet_builder.h. This is the
// only place that includes PCL; the builder keeps its point cloud and kd-tree between calls.
// Built into libmdstream_pcl.so (convert/meshlet_pcl_module.h), which the converter opens only
// when the PCL builder is asked for, and into the static library mdstream_pcl for tests.
#pragma once

#include <memory>

#include "convert/meshlet_builder.h"

namespace mds::convert {

class PclMeshletBuilder final : public MeshletBuilder {
 public:
  PclMeshletBuilder();
  ~PclMeshletBuilder() override;

 protected:
  Status build_impl(std::span<const uint64_t> keys, std::span<const double> xyz, uint32_t meshlet_size,
                    std::vector<uint32_t>& order, std::vector<uint8_t>& sizes) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mds::convert
