// Octree-leaf meshlets (see meshlet_octree.h).
#include "convert/meshlet_octree.h"

namespace mds::convert {

Status OctreeMeshletBuilder::build_impl(std::span<const uint64_t> keys, std::span<const double> /*xyz*/,
                                        uint32_t meshlet_size, std::vector<uint32_t>& order,
                                        std::vector<uint8_t>& sizes) {
  bool unsorted = false;  // branch-free scan; the position is looked up only on failure
  for (size_t i = 1; i < keys.size(); ++i) unsorted |= keys[i] < keys[i - 1];
  if (unsorted)
    for (size_t i = 1; i < keys.size(); ++i)
      if (keys[i] < keys[i - 1]) return make_error(Errc::internal, "octree meshlets: keys not sorted at {}", i);
  leaves_.clear();
  octree_partition(keys, common_cell_level(keys.front(), keys.back()), meshlet_size, leaves_);
  const size_t n = keys.size();
  order.resize(n);
  for (size_t i = 0; i < n; ++i) order[i] = uint32_t(i);
  sizes.resize(leaves_.size());
  for (size_t m = 0; m < leaves_.size(); ++m) sizes[m] = uint8_t(leaves_[m].size());
  return {};
}

}  // namespace mds::convert
