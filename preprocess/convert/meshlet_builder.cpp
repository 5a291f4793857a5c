// Meshlet builder selection and the checks shared by both builders (see meshlet_builder.h).
#include "convert/meshlet_builder.h"

#include <limits>

#include "convert/meshlet_octree.h"
#include "convert/meshlet_pcl_module.h"

namespace mds::convert {

const char* meshlet_builder_name(MeshletBuilderKind kind) {
  switch (kind) {
    case MeshletBuilderKind::pcl: return "pcl";
    case MeshletBuilderKind::octree: return "octree";
  }
  return "?";
}

std::optional<MeshletBuilderKind> parse_meshlet_builder(const std::string& name) {
  if (name == "pcl") return MeshletBuilderKind::pcl;
  if (name == "octree") return MeshletBuilderKind::octree;
  return std::nullopt;
}

Status MeshletBuilder::build(std::span<const uint64_t> keys, std::span<const double> xyz, uint32_t meshlet_size,
                             std::vector<uint32_t>& order, std::vector<uint8_t>& sizes) {
  order.clear();
  sizes.clear();
  if (xyz.size() % 3 != 0) return make_error(Errc::internal, "meshlet builder: position array not a multiple of 3");
  const size_t n = xyz.size() / 3;
  if (keys.size() != n)
    return make_error(Errc::internal, "meshlet builder: {} keys for {} positions", keys.size(), n);
  if (meshlet_size < 1 || meshlet_size > 255)
    return make_error(Errc::invalid_argument, "meshlet size {} outside 1..255", meshlet_size);
  if (n == 0) return {};
  if (n > size_t(std::numeric_limits<int>::max()))
    return make_error(Errc::internal, "meshlet builder: {} particles in one node", n);
  if (n <= meshlet_size) {
    order.resize(n);
    for (size_t i = 0; i < n; ++i) order[i] = uint32_t(i);
    sizes.push_back(uint8_t(n));
    return {};
  }
  order.reserve(n);
  sizes.reserve(n / meshlet_size + 16);
  return build_impl(keys, xyz, meshlet_size, order, sizes);
}

Result<std::unique_ptr<MeshletBuilder>> make_meshlet_builder(MeshletBuilderKind kind) {
  if (kind == MeshletBuilderKind::octree) return std::unique_ptr<MeshletBuilder>(std::make_unique<OctreeMeshletBuilder>());
  MDS_ASSIGN_OR_RETURN(const PclModuleApi* pcl, pcl_module());
  return pcl->make_builder();
}

}  // namespace mds::convert
