// Residency state of the streaming cache: which nodes are on the device, which to fetch next,
// which to evict (issue 4, "Residency by occlusion class").
// Follows Ibrahim et al. §5.1 (occlusion classes O/M/L/P; O = culled with high confidence,
// M = not culled but a poor occluder, L = occluder candidate after P, P = potentially visible,
// the main occluders) and §8 (future work: a GPU cache for data larger than GPU memory), with
// Grottel et al. §3.1 (the visible cells of the previous frame are the first occluders; front to
// back order).
//   eviction (policy occlusion): O first, then M, then L/P; within a group the nodes outside the
//            view (not in the frustum nor in a next view) first, then least recently used first,
//            then farthest first;
//   prefetch (policy occlusion): P, then L, then M (M is drawn but is no occluder), front to
//            back (smaller distance first), larger projected size first among equal distances;
//            O nodes are never requested, so a node classified O before it was ever loaded is
//            never read;
//   policies lru / fifo (for the stress comparison): class-blind; every node in the frustum is
//            fetched front to back; eviction by least recent use / by load order;
//   look-ahead (every policy, while the camera moves): `ahead` = how many of the next views,
//            extrapolated from the camera's motion, contain the node (set_ahead). Within a fetch
//            group the nodes that stay in view longer come first, and among nodes drawn now the
//            ones that leave soonest are evicted first (Belady's rule -- keep what is used again
//            soonest -- with the future guessed from the motion). A node outside the frustum
//            with ahead > 0 is fetched after every wanted node, only into room no wanted node
//            needs; it is not demand (no hit or miss).
// Pure logic, deterministic (ties broken by node index), no threads.
#pragma once

#include <cstdint>
#include <string_view>
#include <span>
#include <tuple>
#include <vector>

#include "core/result.h"
#include "culling/culling_constants.h"

namespace mds::streaming {

// Same numeric values as the renderer's classes (MDS_CULL_CLASS_* in culling_constants.h,
// used by shaders/include/cull_shared.h).
enum NodeClass : uint8_t {
  kClassP = MDS_CULL_CLASS_P,
  kClassL = MDS_CULL_CLASS_L,
  kClassM = MDS_CULL_CLASS_M,
  kClassO = MDS_CULL_CLASS_O,
};
static_assert(kClassP == 0 && kClassL == 1 && kClassM == 2 && kClassO == 3);
char class_letter(uint8_t cls);

enum class Residency : uint8_t { absent, requested, resident };

enum class Policy : uint8_t { occlusion, lru, fifo };
Result<Policy> parse_policy(std::string_view text);
const char* policy_name(Policy p);

struct NodeState {
  Residency residency = Residency::absent;
  uint8_t cls = kClassP;
  bool in_frustum = true;
  bool ever_loaded = false;
  uint8_t ahead = 0;            // next extrapolated views containing it (0 at rest; look-ahead)
  bool failed = false;          // unreadable: never requested again
  uint64_t bytes = 0;           // device bytes when resident
  uint64_t last_use = 0;        // last frame the node was drawn/sampled (touch)
  uint64_t load_seq = 0;        // order of arrival (FIFO)
  float distance = 0;           // camera distance (e.g. to the bounds centre)
  float projected_size = 0;     // projected screen size (the cache: bounding radius / half the image height)
};

class ResidencyTable {
 public:
  ResidencyTable(std::vector<uint64_t> node_bytes, Policy policy);

  size_t size() const { return nodes_.size(); }
  Policy policy() const { return policy_; }
  const NodeState& node(uint32_t i) const { return nodes_[i]; }

  // Per-iteration inputs from the culling loop / camera.
  void set_class(uint32_t i, uint8_t cls) { nodes_[i].cls = cls; }
  void set_view(uint32_t i, float distance, float projected_size, bool in_frustum = true);
  void set_ahead(uint32_t i, uint8_t ahead) { nodes_[i].ahead = ahead; }
  void touch(uint32_t i, uint64_t frame) { nodes_[i].last_use = frame; }
  // All classes back to P (new view, paper §5.1); residency and use history stay.
  void reset_classes();

  // State transitions. Errc::internal on an impossible transition.
  Status mark_requested(uint32_t i);
  Status mark_cancelled(uint32_t i);   // requested -> absent
  Status mark_loaded(uint32_t i);      // requested -> resident
  Status mark_evicted(uint32_t i);     // resident -> absent
  Status mark_failed(uint32_t i);      // requested -> absent, never again
  // A node's device bytes, known better once it was read (--slice thins a node). Precondition
  // (else Errc::internal): the node is not resident.
  Status set_bytes(uint32_t i, uint64_t bytes);

  // Whether the policy wants node i resident now (ignores residency).
  bool wanted(uint32_t i) const;
  // wanted(i), or a look-ahead node (outside the frustum, not failed): worth reading.
  bool fetchable(uint32_t i) const;
  // Absent, fetchable nodes in request order (at most `limit`): wanted ones first.
  std::vector<uint32_t> prefetch_order(size_t limit = SIZE_MAX) const;
  // All resident nodes, first = evicted first.
  std::vector<uint32_t> eviction_order() const;
  // Resident nodes to evict so that `need` bytes fit when `free` are free now, in eviction order.
  // Nodes touched in frame `protect_frame` (drawn this frame) are kept, except class O under the
  // occlusion policy (O is not drawn) and, when `incoming` names the node to be placed, nodes
  // that `incoming` is fetched before (displaces()): a nearer / more important node replaces a
  // farther one that is drawn but not yet known to be occluded. The fetch order is strict, so this
  // cannot cycle. Returns Errc::budget if even that cannot make room (the caller stalls the
  // upload, it does not thrash).
  Result<std::vector<uint32_t>> choose_victims(uint64_t need, uint64_t free, uint64_t protect_frame,
                                               int64_t incoming = -1) const;
  // Bytes choose_victims could free for `incoming` (-1: none).
  uint64_t evictable_bytes(uint64_t protect_frame, int64_t incoming = -1) const;
  // evictable_bytes(protect_frame, order[k]) for every k. Precondition: `order` is in fetch order
  // (prefetch_order(), or a prefix of it). A candidate frees the resident nodes not drawn in
  // `protect_frame` and the drawn ones it displaces, i.e. those after it in the fetch order: the
  // drawn resident nodes are sorted once and passed by a cursor, O(R log R + n) for all instead
  // of O(nodes) per candidate, with a fetch-order comparison for each drawn node.
  std::vector<uint64_t> evictable_bytes_in_order(std::span<const uint32_t> order, uint64_t protect_frame) const;
  // Whether `incoming` may take the place of resident node `resident` drawn this frame.
  bool displaces(uint32_t incoming, uint32_t resident) const { return fetch_before(incoming, resident); }
  // Whether resident node `a` comes before node `b` in the eviction order, were `b` resident,
  // placed and used in frame `frame` (a read that arrived for a node no longer wanted: it is
  // kept only at the expense of nodes evicted before it).
  bool evicted_before(uint32_t a, uint32_t b, uint64_t frame) const;

  uint64_t resident_bytes() const { return resident_bytes_; }
  size_t resident_count() const { return resident_.size(); }
  // The resident nodes, in no particular order (kept by mark_loaded / mark_evicted): the
  // per-placement work (choose_victims) and per-frame passes over resident nodes cost O(resident)
  // rather than O(nodes) -- a store of 10^9 particles has 10^5 nodes of 10k, a pool a few hundred.
  std::span<const uint32_t> resident_nodes() const { return resident_; }
  size_t never_loaded_count() const;

 private:
  bool evict_before(const NodeState& x, uint32_t a, const NodeState& y, uint32_t b) const;
  // The fetch order as a key: group (wanted: P, L, M under the occlusion policy; look-ahead
  // last), more next views first, nearer first, larger on screen first, then the index.
  struct FetchKey {
    int group, neg_ahead;
    float distance, neg_projected;
    uint32_t node;
    bool operator<(const FetchKey& o) const {
      return std::tie(group, neg_ahead, distance, neg_projected, node) <
             std::tie(o.group, o.neg_ahead, o.distance, o.neg_projected, o.node);
    }
  };
  FetchKey fetch_key(uint32_t i) const;
  bool fetch_before(uint32_t a, uint32_t b) const;
  // Node n was drawn in `frame` (touched then), and so is kept by an eviction in that frame:
  // class O under the occlusion policy is not drawn.
  bool drawn_in(const NodeState& n, uint64_t frame) const {
    return n.last_use == frame && !(policy_ == Policy::occlusion && n.cls == kClassO);
  }

  std::vector<NodeState> nodes_;
  Policy policy_;
  uint64_t load_counter_ = 0;
  uint64_t resident_bytes_ = 0;
  std::vector<uint32_t> resident_;      // resident node ids, unordered
  std::vector<uint32_t> resident_pos_;  // node -> its index in resident_ (kNotResident: none)
  static constexpr uint32_t kNotResident = ~0u;
};

}  // namespace mds::streaming
