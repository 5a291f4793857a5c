// Meshlet generation with PCL kd-tree neighbourhoods (paper 000, §6); see meshlet_builder.h.
#include "convert/meshlet_builder.h"

#include <algorithm>
#include <limits>

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace mds::convert {

struct MeshletBuilder::Impl {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
  pcl::KdTreeFLANN<pcl::PointXYZ> tree{true};  // sorted results: nearest first
  pcl::Indices idx;
  std::vector<float> dist;
  std::vector<uint8_t> assigned;
  std::shared_ptr<pcl::Indices> active{new pcl::Indices};
};

MeshletBuilder::MeshletBuilder() : impl_(std::make_unique<Impl>()) {}
MeshletBuilder::~MeshletBuilder() = default;

Status MeshletBuilder::build(std::span<const double> xyz, uint32_t meshlet_size, std::vector<uint32_t>& order,
                             std::vector<uint8_t>& sizes) {
  order.clear();
  sizes.clear();
  if (xyz.size() % 3 != 0) return make_error(Errc::internal, "meshlet builder: position array not a multiple of 3");
  const size_t n = xyz.size() / 3;
  if (meshlet_size < 1 || meshlet_size > 255)
    return make_error(Errc::invalid_argument, "meshlet size {} outside 1..255", meshlet_size);
  if (n == 0) return {};
  if (n > size_t(std::numeric_limits<int>::max()))
    return make_error(Errc::internal, "meshlet builder: {} particles in one node", n);
  order.reserve(n);
  sizes.reserve(n / meshlet_size + 16);

  // Positions relative to the node's minimum, as float: keeps full float precision for
  // far-from-origin data (coordinates of 1e6 with sub-unit spacing).
  double lo[3] = {xyz[0], xyz[1], xyz[2]};
  for (size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], xyz[3 * i + a]);
  auto& cloud = *impl_->cloud;
  cloud.resize(n);
  for (size_t i = 0; i < n; ++i) {
    cloud[i].x = float(xyz[3 * i] - lo[0]);
    cloud[i].y = float(xyz[3 * i + 1] - lo[1]);
    cloud[i].z = float(xyz[3 * i + 2] - lo[2]);
  }
  cloud.width = uint32_t(n);
  cloud.height = 1;
  cloud.is_dense = true;

  auto& assigned = impl_->assigned;
  assigned.assign(n, 0);

  if (n <= meshlet_size) {
    for (size_t i = 0; i < n; ++i) order.push_back(uint32_t(i));
    sizes.push_back(uint8_t(n));
    return {};
  }

  // The kd-tree covers the "active" particles. Once half of them are assigned and a
  // query comes back short, it is rebuilt over the unassigned ones only, so late seeds
  // (isolated leftovers) find free neighbours without ever-wider queries.
  auto& active = *impl_->active;
  active.resize(n);
  for (size_t i = 0; i < n; ++i) active[i] = int(i);
  impl_->tree.setInputCloud(impl_->cloud, impl_->active);
  size_t tree_size = n, tree_assigned = 0;
  size_t remaining = n;
  size_t cursor = 0;  // first possibly unassigned index in Morton order
  while (remaining > 0) {
    while (assigned[cursor]) ++cursor;
    const size_t want = std::min<size_t>(meshlet_size, remaining);
    size_t taken = 0;
    const size_t start = order.size();
    if (remaining <= want) {
      for (size_t i = cursor; i < n; ++i)
        if (!assigned[i]) {
          assigned[i] = 1;
          order.push_back(uint32_t(i));
          ++taken;
        }
    } else {
      size_t k = std::min(tree_size, 2 * size_t(meshlet_size));
      for (;;) {
        impl_->tree.nearestKSearch(cloud[cursor], int(k), impl_->idx, impl_->dist);
        size_t found = 0;
        for (auto j : impl_->idx)
          if (!assigned[size_t(j)] && ++found >= want) break;
        if (found >= want || k >= tree_size) break;
        if (2 * tree_assigned >= tree_size) {
          active.clear();
          for (size_t i = cursor; i < n; ++i)
            if (!assigned[i]) active.push_back(int(i));
          impl_->tree.setInputCloud(impl_->cloud, impl_->active);
          tree_size = active.size();
          tree_assigned = 0;
          k = std::min(tree_size, 2 * size_t(meshlet_size));
        } else {
          k = std::min(tree_size, k * 2);
        }
      }
      // The seed first (duplicates at distance 0 may precede it), then the nearest free ones.
      assigned[cursor] = 1;
      order.push_back(uint32_t(cursor));
      taken = 1;
      for (auto j : impl_->idx) {
        if (taken >= want) break;
        const size_t u = size_t(j);
        if (assigned[u]) continue;
        assigned[u] = 1;
        order.push_back(uint32_t(u));
        ++taken;
      }
    }
    tree_assigned += taken;
    remaining -= taken;
    sizes.push_back(uint8_t(order.size() - start));
  }
  return {};
}

}  // namespace mds::convert
