// Octree-leaf meshlets filled from PCL kd-tree neighbourhoods (paper 000, §6); see meshlet_builder.h.
#include "pcl/meshlet_pcl.h"

#include "convert/octree_partition.h"
#include "pcl/pcl_kdtree.h"

#include <algorithm>
#include <array>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace mds::convert {

struct PclMeshletBuilder::Impl {
  pcl::PointCloud<pcl::PointXYZ> centroids;  // one per octree leaf, relative to the node's first particle
  PclKdTree tree;
  std::vector<KeyRange> leaves;
  std::vector<uint8_t> free;   // per leaf: its particles not yet in a meshlet
  std::vector<uint8_t> taken;  // per particle
  std::vector<size_t> near;    // kd-tree answer: leaf indices, nearest first
  struct Candidate {
    double d2;  // squared distance to the seed's centre
    uint32_t particle, leaf;
    bool operator<(const Candidate& o) const { return d2 < o.d2 || (d2 == o.d2 && particle < o.particle); }
  };
  std::array<Candidate, 256> cand;  // top-up: the nearest candidates so far, sorted (meshlet_size <= 255)

  // Appends the meshlet seeded by leaf l (free[l] > 0) to order/sizes; xyz as build_impl's;
  // `remaining` counts the node's particles not yet in a meshlet.
  void meshlet(size_t l, std::span<const double> xyz, uint32_t meshlet_size, size_t& remaining,
               std::vector<uint32_t>& order, std::vector<uint8_t>& sizes);
  void take(size_t i, size_t leaf, std::vector<uint32_t>& order) {
    taken[i] = 1;
    --free[leaf];
    order.push_back(uint32_t(i));
  }
};

PclMeshletBuilder::PclMeshletBuilder() : impl_(std::make_unique<Impl>()) {}
PclMeshletBuilder::~PclMeshletBuilder() = default;

void PclMeshletBuilder::Impl::meshlet(size_t l, std::span<const double> xyz, uint32_t meshlet_size,
                                      size_t& remaining, std::vector<uint32_t>& order, std::vector<uint8_t>& sizes) {
  const size_t start = order.size();
  double c[3] = {0, 0, 0};  // centre of the seed leaf's free particles
  for (size_t i = leaves[l].begin; i < leaves[l].end; ++i)
    if (!taken[i]) {
      for (int a = 0; a < 3; ++a) c[a] += xyz[3 * i + a];
      take(i, l, order);
    }
  const size_t have = order.size() - start;
  for (int a = 0; a < 3; ++a) c[a] /= double(have);
  remaining -= have;
  size_t need = std::min<size_t>(meshlet_size - have, remaining);
  if (need > 0) {
    // The nearest leaves by centre, widened until they hold enough free particles (late in a
    // node the seed's neighbourhood is mostly used up; at most the whole node).
    const size_t leaf_count = leaves.size();
    // The query point in the cloud's frame (relative to the node's first particle).
    const float q[3] = {float(c[0] - xyz[0]), float(c[1] - xyz[1]), float(c[2] - xyz[2])};
    for (size_t k = kPclNeighbourLeaves;; k *= 2) {
      tree.nearest(q, std::min(k, leaf_count), near);
      size_t available = 0;
      for (const size_t j : near) available += free[j];
      if (available >= need || k >= leaf_count) break;
    }
    // Whole leaves first, nearest first: a leaf taken whole leaves no remnant behind to seed
    // a scattered meshlet later (porous 2M: diag/spacing 4.37 -> 4.12).
    for (const size_t j : near) {
      if (free[j] == 0 || free[j] > need) continue;
      need -= free[j];
      remaining -= free[j];
      for (size_t i = leaves[j].begin; i < leaves[j].end; ++i)
        if (!taken[i]) take(i, j, order);
      if (need == 0) break;
    }
    // The rest: the free particles of those leaves nearest to the seed's centre; ties by index.
    if (need > 0) {
      // The `need` nearest, kept sorted by insertion as they are found (a few of some 40
      // candidates: cheaper than collecting them all and partial_sort's heap).
      size_t count = 0;
      for (const size_t j : near) {
        if (free[j] == 0) continue;
        for (size_t i = leaves[j].begin; i < leaves[j].end; ++i) {
          if (taken[i]) continue;
          const double dx = xyz[3 * i] - c[0], dy = xyz[3 * i + 1] - c[1], dz = xyz[3 * i + 2] - c[2];
          const Candidate x{dx * dx + dy * dy + dz * dz, uint32_t(i), uint32_t(j)};
          size_t t;
          if (count < need) t = count++;
          else if (x < cand[count - 1]) t = count - 1;
          else continue;
          for (; t > 0 && x < cand[t - 1]; --t) cand[t] = cand[t - 1];
          cand[t] = x;
        }
      }
      for (size_t t = 0; t < count; ++t) take(cand[t].particle, cand[t].leaf, order);
      remaining -= count;
    }
  }
  sizes.push_back(uint8_t(order.size() - start));
}

Status PclMeshletBuilder::build_impl(std::span<const uint64_t> keys, std::span<const double> xyz,
                                     uint32_t meshlet_size, std::vector<uint32_t>& order,
                                     std::vector<uint8_t>& sizes) {
  auto& m = *impl_;
  const size_t n = keys.size();
  // 1. The octree leaves of capacity meshlet_size over the node's sorted keys (O(n)).
  m.leaves.clear();
  octree_partition(keys, common_cell_level(keys.front(), keys.back()), meshlet_size, m.leaves);
  const size_t leaf_count = m.leaves.size();
  // 2. The leaves' centres as a PCL cloud, relative to the node's first particle, as float
  //    (keeps full float precision for far-from-origin data: coordinates of 1e6 with
  //    sub-unit spacing). Distances between particles are taken in double.
  m.centroids.resize(leaf_count);
  m.free.resize(leaf_count);
  for (size_t l = 0; l < leaf_count; ++l) {
    const KeyRange r = m.leaves[l];
    double c[3] = {0, 0, 0};
    for (size_t i = r.begin; i < r.end; ++i)
      for (int a = 0; a < 3; ++a) c[a] += xyz[3 * i + a];
    const double inv = 1.0 / double(r.size());
    m.centroids[l].x = float(c[0] * inv - xyz[0]);
    m.centroids[l].y = float(c[1] * inv - xyz[1]);
    m.centroids[l].z = float(c[2] * inv - xyz[2]);
    m.free[l] = uint8_t(r.size());
  }
  m.centroids.width = uint32_t(leaf_count);
  m.centroids.height = 1;
  m.centroids.is_dense = true;
  m.taken.assign(n, 0);
  // 3. Meshlets seeded by the leaves in Morton order; the kd-tree is built on the first query
  //    (a node whose leaves are all full needs none).
  bool tree_built = false;
  size_t remaining = n;
  for (size_t l = 0; l < leaf_count && remaining > 0; ++l) {
    if (m.free[l] == 0) continue;
    if (!tree_built && m.free[l] < meshlet_size) {
      m.tree.build(m.centroids);
      tree_built = true;
    }
    m.meshlet(l, xyz, meshlet_size, remaining, order, sizes);
  }
  return {};
}

}  // namespace mds::convert
