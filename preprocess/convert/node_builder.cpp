// Node building: the shared implicit-octree partition at node scale (see node_builder.h).
#include "convert/node_builder.h"

namespace mds::convert {

std::vector<NodeRange> build_nodes(std::span<const uint64_t> keys, int start_level, uint32_t node_size) {
  std::vector<NodeRange> out;
  octree_partition(keys, start_level, node_size, out);
  return out;
}

std::vector<NodeRange> build_nodes(const XyzMortonKeys& keys, int start_level, uint32_t node_size) {
  std::vector<NodeRange> out;
  octree_partition(keys, start_level, node_size, out);
  return out;
}

}  // namespace mds::convert
