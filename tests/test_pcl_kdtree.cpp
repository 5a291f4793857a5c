// The PCL meshlet builder's kd-tree wrapper (preprocess/pcl/pcl_kdtree.h) against
// pcl::KdTreeFLANN::nearestKSearch, the call it replaces: the same neighbours in the same order
// (indices and their order, which the builder's "nearest first" rules depend on) up to FLANN's
// heap threshold (k <= 250), the same distances rank by rank above it; on uniform points,
// clustered points with exact duplicates (ties), a flat cloud, and k up to the cloud's size.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include <pcl/kdtree/kdtree_flann.h>

#include "pcl/pcl_kdtree.h"

namespace {

// flann/algorithms/nn_index.h: knnSearch uses KNNSimpleResultSet up to this k.
constexpr size_t kKnnHeapThreshold = KNN_HEAP_THRESHOLD;

pcl::PointCloud<pcl::PointXYZ>::Ptr make_cloud(int kind, size_t n, uint32_t seed) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 10.0f);
  std::normal_distribution<float> g(0.0f, 0.5f);
  for (size_t i = 0; i < n; ++i) {
    pcl::PointXYZ p;
    if (kind == 0) {
      p.x = u(rng), p.y = u(rng), p.z = u(rng);
    } else if (kind == 1) {  // 4 blobs; every 5th point repeats the one before (distance ties)
      if (i % 5 == 4 && !cloud->empty()) {
        p = cloud->back();
      } else {
        const float c = 3.0f * float(i % 4);
        p.x = c + g(rng), p.y = g(rng), p.z = g(rng);
      }
    } else {  // flat: a lattice in z = 0 (many equal distances)
      p.x = float(i % 17), p.y = float(i / 17), p.z = 0.0f;
    }
    cloud->push_back(p);
  }
  return cloud;
}

TEST(PclKdTree, SameNeighboursInTheSameOrderAsKdTreeFlann) {
  for (int kind = 0; kind < 3; ++kind)
    for (const size_t n : {1u, 7u, 200u, 900u}) {
      SCOPED_TRACE(testing::Message() << "cloud kind " << kind << ", " << n << " points");
      const auto cloud = make_cloud(kind, n, 40u + uint32_t(kind));
      pcl::KdTreeFLANN<pcl::PointXYZ> reference;  // sorted results by default
      reference.setInputCloud(cloud);
      mds::convert::PclKdTree tree;
      tree.build(*cloud);
      std::mt19937 rng(7);
      std::uniform_int_distribution<size_t> pick(0, n - 1);
      std::normal_distribution<float> jitter(0.0f, 0.3f);
      std::vector<size_t> got;
      for (int q = 0; q < 60; ++q) {
        // Queries at cloud points (ties with duplicates) and near them.
        pcl::PointXYZ p = (*cloud)[pick(rng)];
        if (q % 2) p.x += jitter(rng), p.y += jitter(rng), p.z += jitter(rng);
        for (const size_t k : {size_t(1), size_t(4), size_t(16), n}) {
          if (k > n) continue;
          std::vector<int> ref_idx;
          std::vector<float> ref_d2;
          ASSERT_EQ(reference.nearestKSearch(p, int(k), ref_idx, ref_d2), int(k));
          const float qp[3] = {p.x, p.y, p.z};
          tree.nearest(qp, k, got);
          ASSERT_EQ(got.size(), ref_idx.size()) << "query " << q << ", k " << k;
          for (size_t i = 0; i < k; ++i) {
            // Above FLANN's heap threshold knnSearch collects into a heap (KNNResultSet2), which
            // orders equal distances differently: there the ranks must hold the same distances.
            if (k <= kKnnHeapThreshold) {
              ASSERT_EQ(got[i], size_t(ref_idx[i])) << "query " << q << ", k " << k << ", rank " << i;
            } else {
              const pcl::PointXYZ& c = (*cloud)[got[i]];
              const float dx = c.x - p.x, dy = c.y - p.y, dz = c.z - p.z;
              ASSERT_EQ(dx * dx + dy * dy + dz * dz, ref_d2[i]) << "query " << q << ", k " << k << ", rank " << i;
            }
          }
        }
      }
    }
}

}  // namespace
