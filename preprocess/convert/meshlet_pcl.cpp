// Greedy kd-tree meshlets with PCL (paper 000, §6); see meshlet_builder.h and meshlet_pcl.h.
#include "convert/meshlet_pcl.h"

#include <algorithm>

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace mds::convert {

struct PclMeshletBuilder::Impl {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
  pcl::KdTreeFLANN<pcl::PointXYZ> tree{true};  // sorted results: nearest first
  pcl::Indices idx;
  std::vector<float> dist;
  std::vector<uint8_t> assigned;
  std::shared_ptr<pcl::Indices> active{new pcl::Indices};

  // Greedy meshlets over cloud[0, n) (local indices); appends base + local index to `order`.
  void run(size_t n, size_t base, uint32_t meshlet_size, std::vector<uint32_t>& order, std::vector<uint8_t>& sizes);
};

PclMeshletBuilder::PclMeshletBuilder() : impl_(std::make_unique<Impl>()) {}
PclMeshletBuilder::~PclMeshletBuilder() = default;

void PclMeshletBuilder::Impl::run(size_t n, size_t base, uint32_t meshlet_size, std::vector<uint32_t>& order,
                                  std::vector<uint8_t>& sizes) {
  assigned.assign(n, 0);
  if (n <= meshlet_size) {
    for (size_t i = 0; i < n; ++i) order.push_back(uint32_t(base + i));
    sizes.push_back(uint8_t(n));
    return;
  }
  // The kd-tree covers the "active" particles. Once half of them are assigned and a
  // query comes back short, it is rebuilt over the unassigned ones only, so late seeds
  // (isolated leftovers) find free neighbours without ever-wider queries.
  active->resize(n);
  for (size_t i = 0; i < n; ++i) (*active)[i] = int(i);
  tree.setInputCloud(cloud, active);
  size_t tree_size = n, tree_assigned = 0;
  size_t remaining = n;
  size_t cursor = 0;  // first possibly unassigned index in Morton order
  // First query: twice the meshlet size (measured: smaller k needs more repeated queries).
  const size_t k0 = std::min<size_t>(2 * size_t(meshlet_size), 64);
  while (remaining > 0) {
    while (assigned[cursor]) ++cursor;
    const size_t want = std::min<size_t>(meshlet_size, remaining);
    size_t taken = 0;
    const size_t start = order.size();
    if (remaining <= want) {
      for (size_t i = cursor; i < n; ++i)
        if (!assigned[i]) {
          assigned[i] = 1;
          order.push_back(uint32_t(base + i));
          ++taken;
        }
    } else {
      size_t k = std::min(tree_size, std::max<size_t>(k0, want));
      for (;;) {
        tree.nearestKSearch((*cloud)[cursor], int(k), idx, dist);
        size_t found = 0;
        for (auto j : idx)
          if (!assigned[size_t(j)] && ++found >= want) break;
        if (found >= want || k >= tree_size) break;
        if (2 * tree_assigned >= tree_size) {
          active->clear();
          for (size_t i = cursor; i < n; ++i)
            if (!assigned[i]) active->push_back(int(i));
          tree.setInputCloud(cloud, active);
          tree_size = active->size();
          tree_assigned = 0;
          k = std::min(tree_size, std::max<size_t>(k0, want));
        } else {
          k = std::min(tree_size, k * 2);
        }
      }
      // The seed first (duplicates at distance 0 may precede it), then the nearest free ones.
      assigned[cursor] = 1;
      order.push_back(uint32_t(base + cursor));
      taken = 1;
      for (auto j : idx) {
        if (taken >= want) break;
        const size_t u = size_t(j);
        if (assigned[u]) continue;
        assigned[u] = 1;
        order.push_back(uint32_t(base + u));
        ++taken;
      }
    }
    tree_assigned += taken;
    remaining -= taken;
    sizes.push_back(uint8_t(order.size() - start));
  }
}

Status PclMeshletBuilder::build_impl(std::span<const uint64_t> /*keys*/, std::span<const double> xyz,
                                     uint32_t meshlet_size, std::vector<uint32_t>& order,
                                     std::vector<uint8_t>& sizes) {
  const size_t n = xyz.size() / 3;
  // Morton runs of `chunk` particles, a multiple of the meshlet size, each with its own small
  // kd-tree; a short tail run is folded into the previous run so no run is tiny.
  const size_t chunk = std::max<size_t>(kPclChunk / meshlet_size, 1) * meshlet_size;
  auto& cloud = *impl_->cloud;
  for (size_t s = 0; s < n;) {
    size_t e = std::min(n, s + chunk);
    if (n - e < chunk / 2) e = n;
    const size_t m = e - s;
    // Positions relative to the run's first particle, as float: keeps full float precision
    // for far-from-origin data (coordinates of 1e6 with sub-unit spacing).
    const double o[3] = {xyz[3 * s], xyz[3 * s + 1], xyz[3 * s + 2]};
    cloud.resize(m);
    for (size_t i = 0; i < m; ++i) {
      const double* p = &xyz[3 * (s + i)];
      cloud[i].x = float(p[0] - o[0]);
      cloud[i].y = float(p[1] - o[1]);
      cloud[i].z = float(p[2] - o[2]);
    }
    cloud.width = uint32_t(m);
    cloud.height = 1;
    cloud.is_dense = true;
    impl_->run(m, s, meshlet_size, order, sizes);
    s = e;
  }
  return {};
}

}  // namespace mds::convert
