// See residency.h (Ibrahim et al. §5.1 occlusion classes, §8; Grottel et al. §3.1).
#include "streaming/residency.h"

#include <algorithm>
#include <tuple>

namespace mds::streaming {

char class_letter(uint8_t cls) {
  switch (cls) {
    case kClassP: return 'P';
    case kClassL: return 'L';
    case kClassM: return 'M';
    case kClassO: return 'O';
    default: return '?';
  }
}

Result<Policy> parse_policy(std::string_view text) {
  if (text == "occlusion") return Policy::occlusion;
  if (text == "lru") return Policy::lru;
  if (text == "fifo") return Policy::fifo;
  return make_error(Errc::invalid_argument, "unknown cache policy '{}' (expected occlusion, lru or fifo)", text);
}

const char* policy_name(Policy p) {
  switch (p) {
    case Policy::occlusion: return "occlusion";
    case Policy::lru: return "lru";
    case Policy::fifo: return "fifo";
  }
  return "?";
}

ResidencyTable::ResidencyTable(std::vector<uint64_t> node_bytes, Policy policy) : policy_(policy) {
  nodes_.resize(node_bytes.size());
  for (size_t i = 0; i < node_bytes.size(); ++i) nodes_[i].bytes = node_bytes[i];
  resident_pos_.assign(node_bytes.size(), kNotResident);
}

void ResidencyTable::set_view(uint32_t i, float distance, float projected_size, bool in_frustum) {
  nodes_[i].distance = distance;
  nodes_[i].projected_size = projected_size;
  nodes_[i].in_frustum = in_frustum;
}

void ResidencyTable::reset_classes() {
  for (auto& n : nodes_) n.cls = kClassP;
}

namespace {
const char* residency_name(Residency r) {
  switch (r) {
    case Residency::absent: return "absent";
    case Residency::requested: return "requested";
    case Residency::resident: return "resident";
  }
  return "?";
}
}  // namespace

#define MDS_EXPECT_STATE(i, want, what)                                                                             \
  if (nodes_[i].residency != (want))                                                                                \
    return make_error(Errc::internal, "residency: node {} cannot be {} while {}", i, what, residency_name(nodes_[i].residency))

Status ResidencyTable::mark_requested(uint32_t i) {
  MDS_EXPECT_STATE(i, Residency::absent, "requested");
  if (nodes_[i].failed) return make_error(Errc::internal, "residency: node {} failed before and is never requested again", i);
  nodes_[i].residency = Residency::requested;
  return {};
}

Status ResidencyTable::mark_cancelled(uint32_t i) {
  MDS_EXPECT_STATE(i, Residency::requested, "cancelled");
  nodes_[i].residency = Residency::absent;
  return {};
}

Status ResidencyTable::mark_loaded(uint32_t i) {
  MDS_EXPECT_STATE(i, Residency::requested, "loaded");
  NodeState& n = nodes_[i];
  n.residency = Residency::resident;
  n.ever_loaded = true;
  n.load_seq = ++load_counter_;
  resident_bytes_ += n.bytes;
  resident_pos_[i] = uint32_t(resident_.size());
  resident_.push_back(i);
  return {};
}

Status ResidencyTable::mark_evicted(uint32_t i) {
  MDS_EXPECT_STATE(i, Residency::resident, "evicted");
  nodes_[i].residency = Residency::absent;
  resident_bytes_ -= nodes_[i].bytes;
  const uint32_t at = resident_pos_[i], last = resident_.back();  // swap-remove
  resident_[at] = last;
  resident_pos_[last] = at;
  resident_.pop_back();
  resident_pos_[i] = kNotResident;
  return {};
}

Status ResidencyTable::set_bytes(uint32_t i, uint64_t bytes) {
  if (i >= nodes_.size() || nodes_[i].residency == Residency::resident)
    return make_error(Errc::internal, "residency: set_bytes of node {} which is resident or out of range", i);
  nodes_[i].bytes = bytes;
  return {};
}

Status ResidencyTable::mark_failed(uint32_t i) {
  MDS_EXPECT_STATE(i, Residency::requested, "marked failed");
  nodes_[i].residency = Residency::absent;
  nodes_[i].failed = true;
  return {};
}

#undef MDS_EXPECT_STATE

bool ResidencyTable::wanted(uint32_t i) const {
  const NodeState& n = nodes_[i];
  if (n.failed || !n.in_frustum) return false;
  if (policy_ == Policy::occlusion) return n.cls != kClassO;
  return true;
}

bool ResidencyTable::fetchable(uint32_t i) const {
  const NodeState& n = nodes_[i];
  return wanted(i) || (n.ahead > 0 && !n.in_frustum && !n.failed);
}

namespace {
// Eviction group under the occlusion policy: O first, then M, then L and P together.
int evict_group(uint8_t cls) { return cls == kClassO ? 0 : cls == kClassM ? 1 : 2; }
// Fetch group under the occlusion policy: P, then L, then M.
int fetch_group(uint8_t cls) { return cls == kClassP ? 0 : cls == kClassL ? 1 : 2; }
}  // namespace

bool ResidencyTable::evict_before(const NodeState& x, uint32_t a, const NodeState& y, uint32_t b) const {
  switch (policy_) {
    case Policy::occlusion: {
      // Within a group, a node outside the view (not in the frustum, not in a next view) before
      // one in it: an occluded node in the frustum may show through a gap as the camera moves,
      // one the camera has passed only comes back when it turns.
      const int vx = x.in_frustum || x.ahead > 0, vy = y.in_frustum || y.ahead > 0;
      // farthest first: compare -distance
      return std::make_tuple(evict_group(x.cls), vx, x.last_use, x.ahead, -x.distance, a) <
             std::make_tuple(evict_group(y.cls), vy, y.last_use, y.ahead, -y.distance, b);
    }
    case Policy::lru:
      return std::make_tuple(x.last_use, x.ahead, -x.distance, a) < std::make_tuple(y.last_use, y.ahead, -y.distance, b);
    case Policy::fifo:
      return std::make_tuple(x.load_seq, a) < std::make_tuple(y.load_seq, b);
  }
  return a < b;
}

bool ResidencyTable::evicted_before(uint32_t a, uint32_t b, uint64_t frame) const {
  NodeState y = nodes_[b];
  y.last_use = frame;
  y.load_seq = load_counter_ + 1;
  return evict_before(nodes_[a], a, y, b);
}

ResidencyTable::FetchKey ResidencyTable::fetch_key(uint32_t i) const {
  const NodeState& x = nodes_[i];
  // Look-ahead nodes (not wanted now) after every wanted node.
  const int g = !wanted(i) ? 3 : policy_ == Policy::occlusion ? fetch_group(x.cls) : 0;
  return {g, -int(x.ahead), x.distance, -x.projected_size, i};
}

bool ResidencyTable::fetch_before(uint32_t a, uint32_t b) const { return fetch_key(a) < fetch_key(b); }

std::vector<uint32_t> ResidencyTable::prefetch_order(size_t limit) const {
  // The keys once per candidate, then a selection of the first `limit` (linear) and a sort of
  // those: the plan usually takes a window of a few dozen from thousands of candidates (11,300
  // nodes at 8M particles: the full sort with a key made per comparison was most of the cache's
  // update on a moving frame).
  std::vector<FetchKey> keys;
  for (uint32_t i = 0; i < nodes_.size(); ++i)
    if (nodes_[i].residency == Residency::absent && fetchable(i)) keys.push_back(fetch_key(i));
  if (limit < keys.size()) {
    std::nth_element(keys.begin(), keys.begin() + std::ptrdiff_t(limit), keys.end());
    keys.resize(limit);
  }
  std::sort(keys.begin(), keys.end());
  std::vector<uint32_t> out(keys.size());
  for (size_t k = 0; k < keys.size(); ++k) out[k] = keys[k].node;
  return out;
}

std::vector<uint32_t> ResidencyTable::eviction_order() const {
  std::vector<uint32_t> out(resident_.begin(), resident_.end());
  std::sort(out.begin(), out.end(), [&](uint32_t a, uint32_t b) { return evict_before(nodes_[a], a, nodes_[b], b); });
  return out;
}

Result<std::vector<uint32_t>> ResidencyTable::choose_victims(uint64_t need, uint64_t free, uint64_t protect_frame,
                                                             int64_t incoming) const {
  std::vector<uint32_t> victims;
  if (need <= free) return victims;
  uint64_t gained = free;
  // eviction_order(), taken from a heap one node at a time: a placement usually needs the first
  // few, and sorting every resident node for each of a frame's placements cost ~10 us per node
  // placed (ablation 1M jumps, 69 placements in a frame).
  std::vector<uint32_t> heap(resident_.begin(), resident_.end());
  const auto after = [&](uint32_t a, uint32_t b) { return evict_before(nodes_[b], b, nodes_[a], a); };
  std::make_heap(heap.begin(), heap.end(), after);
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end(), after);
    const uint32_t i = heap.back();
    heap.pop_back();
    const NodeState& n = nodes_[i];
    const bool drawn_now = drawn_in(n, protect_frame);
    if (drawn_now && !(incoming >= 0 && displaces(uint32_t(incoming), i))) continue;
    victims.push_back(i);
    gained += n.bytes;
    if (gained >= need) return victims;
  }
  return make_error(Errc::budget, "residency: {} bytes needed, only {} can be freed without evicting nodes drawn in frame {}", need, gained,
                    protect_frame);
}

uint64_t ResidencyTable::evictable_bytes(uint64_t protect_frame, int64_t incoming) const {
  uint64_t b = 0;
  for (const uint32_t i : resident_) {
    const NodeState& n = nodes_[i];
    const bool drawn_now = drawn_in(n, protect_frame);
    if (!drawn_now || (incoming >= 0 && displaces(uint32_t(incoming), i))) b += n.bytes;
  }
  return b;
}

std::vector<uint64_t> ResidencyTable::evictable_bytes_in_order(std::span<const uint32_t> order,
                                                               uint64_t protect_frame) const {
  uint64_t free_anyway = 0;   // resident, not drawn in protect_frame
  std::vector<uint32_t> drawn;  // resident and drawn: evictable only for a candidate before them
  for (const uint32_t i : resident_) {
    const NodeState& n = nodes_[i];
    const bool drawn_now = drawn_in(n, protect_frame);
    if (drawn_now)
      drawn.push_back(i);
    else
      free_anyway += n.bytes;
  }
  std::sort(drawn.begin(), drawn.end(), [&](uint32_t a, uint32_t b) { return fetch_before(a, b); });
  uint64_t after = 0;  // bytes of the drawn nodes from the cursor on
  for (uint32_t i : drawn) after += nodes_[i].bytes;
  std::vector<uint64_t> out(order.size());
  size_t cursor = 0;
  for (size_t k = 0; k < order.size(); ++k) {
    // Drawn nodes fetched before this candidate are not displaced by it (nor by later ones).
    while (cursor < drawn.size() && !fetch_before(order[k], drawn[cursor])) after -= nodes_[drawn[cursor++]].bytes;
    out[k] = free_anyway + after;
  }
  return out;
}

size_t ResidencyTable::never_loaded_count() const {
  size_t c = 0;
  for (const auto& n : nodes_) c += n.ever_loaded ? 0 : 1;
  return c;
}

}  // namespace mds::streaming
