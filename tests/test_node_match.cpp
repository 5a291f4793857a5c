// Node correspondence by box overlap (streaming/node_match.h): the IoU of two boxes, the grid
// matcher against a brute-force search over random boxes, ties, thresholds and hostile boxes,
// and the carried set of a prior view.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "streaming/node_match.h"

namespace mds::streaming {
namespace {

NodeBox box(double x0, double y0, double z0, double x1, double y1, double z1) {
  return NodeBox{glm::dvec3(x0, y0, z0), glm::dvec3(x1, y1, z1)};
}

TEST(NodeMatch, IouOfBoxes) {
  const NodeBox unit = box(0, 0, 0, 1, 1, 1);
  EXPECT_DOUBLE_EQ(box_iou(unit, unit), 1.0);
  EXPECT_DOUBLE_EQ(box_iou(unit, box(0.5, 0, 0, 1.5, 1, 1)), 0.5 / 1.5);  // half overlaps: 1/3
  EXPECT_DOUBLE_EQ(box_iou(unit, box(0, 0, 0, 2, 2, 2)), 1.0 / 8.0);      // contained
  EXPECT_DOUBLE_EQ(box_iou(unit, box(2, 2, 2, 3, 3, 3)), 0.0);            // apart
  EXPECT_DOUBLE_EQ(box_iou(unit, box(1, 0, 0, 2, 1, 1)), 0.0);            // touching faces
  EXPECT_DOUBLE_EQ(box_iou(box(0, 0, 0, 1, 1, 0), box(0, 0, 0, 1, 1, 0)), 1.0);  // equal flat boxes
  EXPECT_DOUBLE_EQ(box_iou(box(0, 0, 0, 1, 1, 0), box(0, 0, 0, 1, 0.5, 0)), 0.0);
  EXPECT_DOUBLE_EQ(box_iou(unit, box(0, 0, 0.5, 1, 1, 0.5)), 0.0);        // a flat box inside
}

TEST(NodeMatch, GridMatchesBruteForce) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> pos(-50.0, 50.0), size(1.0, 6.0), jitter(-0.2, 0.2);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<NodeBox> prior, next;
    for (int i = 0; i < 700; ++i) {
      const glm::dvec3 lo(pos(rng), pos(rng), pos(rng));
      prior.push_back({lo, lo + glm::dvec3(size(rng), size(rng), size(rng))});
    }
    // The next frame: most boxes moved a little, some new, a large one over many.
    for (const NodeBox& b : prior) {
      const glm::dvec3 d(jitter(rng), jitter(rng), jitter(rng));
      next.push_back({b.lo + d, b.hi + d + glm::dvec3(jitter(rng) * 0.3)});
      if (next.size() % 7 == 0) {
        const glm::dvec3 lo(pos(rng), pos(rng), pos(rng));
        next.push_back({lo, lo + glm::dvec3(size(rng))});
      }
    }
    next.push_back(box(-60, -60, -60, 60, 60, 60));
    next.push_back(box(500, 500, 500, 501, 501, 501));  // outside the prior grid
    for (const double min_iou : {0.5, 0.2, 1e-9}) {
      const std::vector<int32_t> got = match_boxes(prior, next, min_iou);
      ASSERT_EQ(got.size(), next.size());
      size_t matched = 0;
      for (size_t n = 0; n < next.size(); ++n) {
        double best = 0.0;
        int32_t want = -1;
        for (size_t p = 0; p < prior.size(); ++p) {
          const double iou = box_iou(prior[p], next[n]);
          if (iou > best) best = iou, want = int32_t(p);
        }
        if (best < min_iou) want = -1;
        EXPECT_EQ(got[n], want) << "trial " << trial << " box " << n << " min_iou " << min_iou;
        matched += want >= 0;
      }
      EXPECT_GT(matched, prior.size() / 2) << "the jittered boxes match their origin";
    }
  }
}

TEST(NodeMatch, TiesGoToTheLowerIndexAndThresholdsHold) {
  const std::vector<NodeBox> prior = {box(1, 0, 0, 2, 1, 1), box(0, 0, 0, 1, 1, 1), box(0, 0, 0, 1, 1, 1)};
  const std::vector<NodeBox> next = {box(0, 0, 0, 1, 1, 1), box(0.5, 0, 0, 1.5, 1, 1)};
  EXPECT_EQ(match_boxes(prior, next, 0.5), (std::vector<int32_t>{1, -1}));  // 1/3 each: below 0.5
  EXPECT_EQ(match_boxes(prior, next, 0.3), (std::vector<int32_t>{1, 0}));   // ties: the lower index
  EXPECT_EQ(match_boxes(prior, next, 0.0), (std::vector<int32_t>{-1, -1})) << "an IoU of 0 matches nothing";
  EXPECT_EQ(match_boxes({}, next, 0.5), (std::vector<int32_t>{-1, -1}));
  EXPECT_TRUE(match_boxes(prior, {}, 0.5).empty());
}

TEST(NodeMatch, NonFiniteBoxesMatchNothing) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const std::vector<NodeBox> prior = {box(0, 0, 0, 1, 1, 1), box(nan, 0, 0, 1, 1, 1), box(0, 0, 0, inf, 1, 1),
                                      box(5, 5, 5, 6, 6, 6)};
  const std::vector<NodeBox> next = {box(0, 0, 0, 1, 1, 1), box(nan, nan, nan, nan, nan, nan), box(-inf, 0, 0, 1, 1, 1),
                                     box(5, 5, 5, 6, 6, 6.1)};
  EXPECT_EQ(match_boxes(prior, next, 0.5), (std::vector<int32_t>{0, -1, -1, 3}));
  const std::vector<NodeBox> only_bad = {box(nan, 0, 0, 1, 1, 1)};
  EXPECT_EQ(match_boxes(only_bad, next, 0.5), (std::vector<int32_t>(4, -1)));
}

TEST(NodeMatch, CarriedNodesAreThoseMatchedToAWantedNode) {
  PriorView prior;
  prior.boxes = {box(0, 0, 0, 1, 1, 1), box(2, 0, 0, 3, 1, 1), box(4, 0, 0, 5, 1, 1)};
  prior.wanted = {1, 0, 1};
  EXPECT_EQ(prior.wanted_count(), 2u);
  // Moved a little along x; the third is gone, a new one appeared far away.
  const std::vector<NodeBox> next = {box(2.1, 0, 0, 3.1, 1, 1), box(0.1, 0, 0, 1.1, 1, 1), box(9, 0, 0, 10, 1, 1)};
  EXPECT_EQ(carried_wanted(prior, next, 0.5), (std::vector<uint8_t>{0, 1, 0}));
}

}  // namespace
}  // namespace mds::streaming
