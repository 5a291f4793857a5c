// Greedy kd-tree meshlets with PCL (paper 000, §6); see meshlet_builder.h and meshlet_pcl.h.
#include "pcl/meshlet_pcl.h"

#include <algorithm>
#include <optional>

#include <flann/flann.hpp>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace mds::convert {

namespace {

// PCL's kd-tree, queried one point at a time. pcl::KdTreeFLANN is a FLANN KDTreeSingleIndex
// (leaf size 15, L2_Simple<float>, exact search) behind two costs a one-query call pays every
// time: setInputCloud copies the cloud into a new array with an index map, and every
// nearestKSearch goes through flann::NNIndex::knnSearch, whose batch loop is an OpenMP
// parallel region -- a libgomp team start and a futex wake per query (two thirds of a 256-point
// run's tree time: 37 -> 10 us for a build and 8 queries, measured alone). This is the same
// index over the cloud's own memory (PointXYZ's 16-byte stride), asked through the
// single-query findNeighbors with the result set knnSearch uses below the heap threshold
// (KNNSimpleResultSet, sorted by insertion): the same neighbours in the same order, so the
// same meshlets (stores compared byte for byte against the pcl::KdTreeFLANN version).
class PclKdTree {
 public:
  using Index = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;
  static constexpr int kLeafMaxSize = 15;  // pcl::KdTreeFLANN::setInputCloud's KDTreeSingleIndexParams

  void build(const pcl::PointCloud<pcl::PointXYZ>& cloud) {
    static_assert(sizeof(pcl::PointXYZ) % sizeof(float) == 0);
    const flann::Matrix<float> points(const_cast<float*>(&cloud[0].x), cloud.size(), 3, sizeof(pcl::PointXYZ));
    index_.emplace(points, flann::KDTreeSingleIndexParams(kLeafMaxSize));  // reorders: copies the points
    index_->buildIndex();
  }

  // The k nearest points to q (k <= the cloud's size), nearest first, into idx.
  void nearest(const pcl::PointXYZ& q, size_t k, std::vector<size_t>& idx) {
    if (!result_ || result_k_ != k) {
      result_.emplace(k);
      result_k_ = k;
    }
    result_->clear();
    const float p[3] = {q.x, q.y, q.z};
    index_->findNeighbors(*result_, p, params_);
    idx.resize(std::min(result_->size(), k));
    dist_.resize(idx.size());
    result_->copy(idx.data(), dist_.data(), idx.size(), true);
  }

 private:
  std::optional<Index> index_;
  std::optional<flann::KNNSimpleResultSet<float>> result_;
  size_t result_k_ = 0;
  std::vector<float> dist_;
  flann::SearchParams params_{-1, 0.0f, true};  // pcl::KdTreeFLANN's param_k_: exact, sorted
};

}  // namespace

struct PclMeshletBuilder::Impl {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
  PclKdTree tree;
  std::vector<size_t> idx;
  std::vector<uint8_t> assigned;
  std::vector<std::pair<float, uint32_t>> cand;  // exact fallback: (squared distance, run index)
  std::vector<uint32_t> free_list;  // exact fallback: unassigned run indices, ascending (compacted lazily)

  // Greedy meshlets over cloud[0, n) (local indices); appends base + local index to `order`.
  void run(size_t n, size_t base, uint32_t meshlet_size, std::vector<uint32_t>& order, std::vector<uint8_t>& sizes);
};

PclMeshletBuilder::PclMeshletBuilder() : impl_(std::make_unique<Impl>()) {}
PclMeshletBuilder::~PclMeshletBuilder() = default;

void PclMeshletBuilder::Impl::run(size_t n, size_t base, uint32_t meshlet_size, std::vector<uint32_t>& order,
                                  std::vector<uint8_t>& sizes) {
  assigned.assign(n, 0);
  free_list.resize(n);
  for (size_t i = 0; i < n; ++i) free_list[i] = uint32_t(i);
  if (n <= meshlet_size) {
    for (size_t i = 0; i < n; ++i) order.push_back(uint32_t(base + i));
    sizes.push_back(uint8_t(n));
    return;
  }
  // One kd-tree over the whole run, built once, on the first query (the whole cloud: PCL's
  // identity index mapping); a run left entirely to the exact scan builds none.
  bool tree_built = false;
  size_t remaining = n;
  size_t cursor = 0;  // first possibly unassigned index in Morton order
  // Query size: twice the meshlet size (measured on porous 10M: k 16 or 24 leave more meshlets
  // to the exact scan below, 82% and 66% instead of 45%, for about the same total time).
  const size_t k = std::min(n, std::max<size_t>(std::min<size_t>(2 * size_t(meshlet_size), 64), meshlet_size));
  // The last kPclScanMeshlets meshlets of a run are filled by the exact scan below without
  // asking the tree: late in a run most of a seed's k nearest are taken (the query comes back
  // short), and the scan of the few free particles is cheaper than a query (meshlet_builder.h).
  const size_t scan_below = size_t(kPclScanMeshlets) * meshlet_size;
  while (remaining > 0) {
    while (assigned[cursor]) ++cursor;
    const size_t want = std::min<size_t>(meshlet_size, remaining);
    const size_t start = order.size();
    assigned[cursor] = 1;
    order.push_back(uint32_t(base + cursor));
    size_t taken = 1;
    if (remaining <= want) {
      for (size_t i = cursor + 1; i < n; ++i)
        if (!assigned[i]) {
          assigned[i] = 1;
          order.push_back(uint32_t(base + i));
          ++taken;
        }
    } else {
      size_t found = 0;  // free neighbours other than the seed among the k nearest
      if (remaining > scan_below) {
        if (!tree_built) {
          tree.build(*cloud);
          tree_built = true;
        }
        tree.nearest((*cloud)[cursor], k, idx);
        for (auto j : idx)
          if (!assigned[size_t(j)] && ++found >= want - 1) break;
      }
      if (found >= want - 1) {
        // The nearest free ones (duplicates at distance 0 may precede the seed).
        for (auto j : idx) {
          if (taken >= want) break;
          const size_t u = size_t(j);
          if (assigned[u]) continue;
          assigned[u] = 1;
          order.push_back(uint32_t(base + u));
          ++taken;
        }
      } else {
        // Too many of the k nearest are taken (late seeds among leftovers), or the run's tail:
        // the nearest free particles of the run by an exact scan of the unassigned ones, ties
        // by index. The same meshlet as widening the query or rebuilding the tree over the
        // unassigned particles (what this did before), at a fraction of the cost: the run has
        // at most a few hundred particles and most of them are assigned by now.
        // The unassigned ones come from the free list, which drops the assigned entries as it
        // is walked (so the scans cost what is left, not the run's size). The want - 1 nearest,
        // ordered by (squared distance, index), are kept in a small sorted array while walking.
        const auto& q = (*cloud)[cursor];
        const size_t limit = want - 1;
        cand.clear();
        size_t kept = 0;
        for (const uint32_t i : free_list) {
          if (assigned[i] || limit == 0) continue;
          free_list[kept++] = i;
          const auto& p = (*cloud)[i];
          const float dx = p.x - q.x, dy = p.y - q.y, dz = p.z - q.z;
          const std::pair<float, uint32_t> c{dx * dx + dy * dy + dz * dz, i};
          if (cand.size() == limit) {
            if (!(c < cand.back())) continue;
            cand.pop_back();
          }
          cand.insert(std::upper_bound(cand.begin(), cand.end(), c), c);
        }
        free_list.resize(kept);
        const size_t take = cand.size();
        for (size_t c = 0; c < take; ++c) {
          assigned[cand[c].second] = 1;
          order.push_back(uint32_t(base + cand[c].second));
        }
        taken += take;
      }
    }
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
