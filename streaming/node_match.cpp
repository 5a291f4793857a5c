// Node correspondence across stores by box overlap; see node_match.h.
#include "streaming/node_match.h"

#include <algorithm>
#include <cmath>

namespace mds::streaming {

namespace {
bool finite(const NodeBox& b) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(b.lo[k]) || !std::isfinite(b.hi[k])) return false;
  return true;
}
double volume(const NodeBox& b) {
  const glm::dvec3 e = glm::max(b.hi - b.lo, glm::dvec3(0.0));
  return e.x * e.y * e.z;
}
}  // namespace

std::vector<NodeBox> node_boxes(const store::StoreReader& reader) {
  std::vector<NodeBox> boxes;
  boxes.reserve(reader.nodes().size());
  for (const store::NodeEntry& e : reader.nodes()) {
    NodeBox b;
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = e.center_min[k] - double(e.max_radius);
      b.hi[k] = e.center_max[k] + double(e.max_radius);
    }
    boxes.push_back(b);
  }
  return boxes;
}

double box_iou(const NodeBox& a, const NodeBox& b) {
  const NodeBox inter{glm::max(a.lo, b.lo), glm::min(a.hi, b.hi)};
  if (inter.lo.x > inter.hi.x || inter.lo.y > inter.hi.y || inter.lo.z > inter.hi.z) return 0.0;
  const double vi = volume(inter), va = volume(a), vb = volume(b);
  const double vu = va + vb - vi;
  if (vu <= 0.0) return a.lo == b.lo && a.hi == b.hi ? 1.0 : 0.0;  // both flat
  return std::clamp(vi / vu, 0.0, 1.0);
}

std::vector<int32_t> match_boxes(std::span<const NodeBox> prior, std::span<const NodeBox> next, double min_iou) {
  std::vector<int32_t> match(next.size(), -1);
  if (prior.empty() || next.empty() || !(min_iou > 0.0)) return match;
  // A uniform grid over the prior boxes, about one box per cell (at most 64 cells per axis).
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (const NodeBox& b : prior) {
    if (!finite(b)) continue;  // matches nothing
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) return match;
  const int side = std::clamp(int(std::ceil(std::cbrt(double(prior.size())))), 1, 64);
  const glm::dvec3 extent = glm::max(hi - lo, glm::dvec3(1e-300));
  const glm::dvec3 scale = double(side) / extent;
  auto cell_range = [&](const NodeBox& b, glm::ivec3& c0, glm::ivec3& c1) {
    // Boxes reaching outside the grid are clamped to its border cells: no prior box lies beyond them.
    // (Clamped in double: the conversion of a value beyond int is undefined.)
    const glm::dvec3 top(double(side - 1));
    c0 = glm::ivec3(glm::clamp(glm::floor((b.lo - lo) * scale), glm::dvec3(0.0), top));
    c1 = glm::ivec3(glm::clamp(glm::floor((b.hi - lo) * scale), glm::dvec3(0.0), top));
  };
  auto cell_index = [&](int x, int y, int z) { return size_t((z * side + y) * side + x); };
  const size_t cells = size_t(side) * size_t(side) * size_t(side);
  // CSR: count, prefix, fill.
  std::vector<uint32_t> first(cells + 1, 0);
  glm::ivec3 c0, c1;
  for (const NodeBox& b : prior) {
    if (!finite(b)) continue;
    cell_range(b, c0, c1);
    for (int z = c0.z; z <= c1.z; ++z)
      for (int y = c0.y; y <= c1.y; ++y)
        for (int x = c0.x; x <= c1.x; ++x) ++first[cell_index(x, y, z) + 1];
  }
  for (size_t c = 0; c < cells; ++c) first[c + 1] += first[c];
  std::vector<uint32_t> members(first[cells]);
  std::vector<uint32_t> fill(first.begin(), first.end() - 1);
  for (uint32_t p = 0; p < prior.size(); ++p) {
    if (!finite(prior[p])) continue;
    cell_range(prior[p], c0, c1);
    for (int z = c0.z; z <= c1.z; ++z)
      for (int y = c0.y; y <= c1.y; ++y)
        for (int x = c0.x; x <= c1.x; ++x) members[fill[cell_index(x, y, z)]++] = p;
  }
  // Each next box against the prior boxes of the cells it overlaps, each prior box once.
  std::vector<uint32_t> seen(prior.size(), UINT32_MAX);
  for (uint32_t n = 0; n < next.size(); ++n) {
    const NodeBox& b = next[n];
    if (!finite(b)) continue;
    if (b.hi.x < lo.x || b.hi.y < lo.y || b.hi.z < lo.z || b.lo.x > hi.x || b.lo.y > hi.y || b.lo.z > hi.z) continue;
    cell_range(b, c0, c1);
    double best = 0.0;
    int32_t best_p = -1;
    for (int z = c0.z; z <= c1.z; ++z)
      for (int y = c0.y; y <= c1.y; ++y)
        for (int x = c0.x; x <= c1.x; ++x) {
          const size_t c = cell_index(x, y, z);
          for (uint32_t k = first[c]; k < first[c + 1]; ++k) {
            const uint32_t p = members[k];
            if (seen[p] == n) continue;
            seen[p] = n;
            const double iou = box_iou(prior[p], b);
            if (iou > best || (iou == best && best_p >= 0 && int32_t(p) < best_p)) {
              best = iou;
              best_p = int32_t(p);
            }
          }
        }
    if (best_p >= 0 && best >= min_iou) match[n] = best_p;
  }
  return match;
}

size_t PriorView::wanted_count() const { return size_t(std::count(wanted.begin(), wanted.end(), uint8_t(1))); }

std::vector<uint8_t> carried_wanted(const PriorView& prior, std::span<const NodeBox> next, double min_iou) {
  const std::vector<int32_t> match = match_boxes(prior.boxes, next, min_iou);
  std::vector<uint8_t> out(next.size(), 0);
  for (size_t n = 0; n < next.size(); ++n)
    if (match[n] >= 0 && size_t(match[n]) < prior.wanted.size()) out[n] = prior.wanted[size_t(match[n])];
  return out;
}

}  // namespace mds::streaming
