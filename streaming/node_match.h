// Which node of one store is "the same" as a node of another store of the same data: the frames
// of a series (a trajectory converted frame by frame, store/series.h) are partitioned anew, so a
// node index means nothing across them, but with the small motion between frames a node's box
// is nearly where a node of the frame before had its box. Matching by the boxes' intersection
// over union (IoU, the Jaccard index of the two volumes) carries what a streaming cache knew of
// the view before -- which nodes it wanted -- to the next store (Grottel et al., paper 002,
// §3.1: the data visible in the previous frame are the first occluders of the next; here across
// frames of the data rather than of the camera). Pure geometry, no Vulkan, no threads.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "store/store_reader.h"

namespace mds::streaming {

struct NodeBox {
  glm::dvec3 lo{0.0}, hi{0.0};  // world coordinates; lo <= hi on every axis
};

// The world box of every node of `reader`: its directory's centre bounds (double precision)
// grown by its largest radius.
std::vector<NodeBox> node_boxes(const store::StoreReader& reader);

// Volume of the intersection over the volume of the union, in [0, 1]. Boxes of zero volume
// (flat on an axis) are compared by that: two equal boxes 1, otherwise 0 unless they overlap
// with volume.
double box_iou(const NodeBox& a, const NodeBox& b);

// For each box of `next`, the index of the box of `prior` with the largest IoU (the lower index
// among equals) when that IoU is at least `min_iou` (> 0), else -1. Precondition: min_iou > 0
// (an IoU of 0 matches nothing). Uses a uniform grid over the prior boxes: about
// O(P + N) for boxes of similar size, each box scattered into the cells it overlaps.
std::vector<int32_t> match_boxes(std::span<const NodeBox> prior, std::span<const NodeBox> next, double min_iou);

// What a streaming cache knew about its view when its store was replaced (a series step, or a
// renderer made again): every node's box and whether the view wanted it (in the frustum and not
// in class O: the nodes it drew or was reading).
struct PriorView {
  std::vector<NodeBox> boxes;
  std::vector<uint8_t> wanted;  // parallel to boxes: 1 = wanted
  size_t wanted_count() const;
};

// The nodes of `next` whose match in the prior view (match_boxes, min_iou) was wanted there:
// 1 per such node, 0 otherwise (no match, or a node the view did not want).
std::vector<uint8_t> carried_wanted(const PriorView& prior, std::span<const NodeBox> next, double min_iou);

}  // namespace mds::streaming
