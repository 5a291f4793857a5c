// PCL's kd-tree (pcl::KdTreeFLANN's FLANN index) asked one point at a time, for the PCL meshlet
// builder (meshlet_pcl.h). Header-only so that tests/test_pcl_kdtree.cpp can compare it with
// pcl::KdTreeFLANN itself. Includes FLANN: only for code linked with PCL.
#pragma once

#include <algorithm>
#include <cstddef>
#include <optional>
#include <vector>

#include <flann/flann.hpp>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace mds::convert {

// PCL's kd-tree, queried one point at a time. pcl::KdTreeFLANN is a FLANN KDTreeSingleIndex
// (leaf size 15, L2_Simple<float>, exact search) behind two costs a one-query call pays every
// time: setInputCloud copies the cloud into a new array with an index map, and every
// nearestKSearch goes through flann::NNIndex::knnSearch, whose batch loop is an OpenMP
// parallel region -- a libgomp team start and a futex wake per query (two thirds of a 256-point
// run's tree time: 37 -> 10 us for a build and 8 queries, measured alone). This is the same
// index over the cloud's own memory (PointXYZ's 16-byte stride), asked through the
// single-query findNeighbors with the result set knnSearch uses below the heap threshold
// (KNNSimpleResultSet, sorted by insertion): the same neighbours in the same order as
// nearestKSearch for k <= 250 (FLANN's KNN_HEAP_THRESHOLD; above it knnSearch collects into a
// heap, which orders equal distances differently: the same distances rank by rank). Checked
// by tests/test_pcl_kdtree.cpp; stores were compared byte for byte against the
// pcl::KdTreeFLANN version when this was introduced (06fb563). The PCL meshlet builder's cloud
// is the octree leaves' centres, one tree per node.
class PclKdTree {
 public:
  using Index = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;
  static constexpr int kLeafMaxSize = 15;  // pcl::KdTreeFLANN::setInputCloud's KDTreeSingleIndexParams

  // Precondition: cloud non-empty. The index copies the points (FLANN's reorder), so the cloud
  // may change or go after build().
  void build(const pcl::PointCloud<pcl::PointXYZ>& cloud) {
    static_assert(sizeof(pcl::PointXYZ) % sizeof(float) == 0);
    const flann::Matrix<float> points(const_cast<float*>(&cloud[0].x), cloud.size(), 3, sizeof(pcl::PointXYZ));
    index_.emplace(points, flann::KDTreeSingleIndexParams(kLeafMaxSize));  // reorders: copies the points
    index_->buildIndex();
  }

  // The k nearest points to q (k <= the cloud's size), nearest first, into idx.
  void nearest(const float q[3], size_t k, std::vector<size_t>& idx) {
    if (!result_ || result_k_ != k) {
      result_.emplace(k);
      result_k_ = k;
    }
    result_->clear();
    index_->findNeighbors(*result_, q, params_);
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

}  // namespace mds::convert
