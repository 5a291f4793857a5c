// Tests of streaming/residency.h: eviction and prefetch order by occlusion class (Ibrahim et al.
// §5.1 classes), never-loaded O nodes never requested, LRU/FIFO policies.
#include <gtest/gtest.h>

#include "streaming/residency.h"

using namespace mds;
using namespace mds::streaming;

namespace {
// Deterministic random tables: next(n) is in [0, n) (a 64-bit LCG, Knuth's MMIX constants).
struct Lcg {
  uint64_t state;
  uint32_t operator()(uint32_t n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t((state >> 33) % n);
  }
};

void load(ResidencyTable& t, uint32_t i) {
  ASSERT_TRUE(t.mark_requested(i).ok());
  ASSERT_TRUE(t.mark_loaded(i).ok());
}
}  // namespace

TEST(StreamingResidency, ClassIdsMatchRenderer) {
  EXPECT_EQ(kClassP, MDS_CULL_CLASS_P);
  EXPECT_EQ(kClassL, MDS_CULL_CLASS_L);
  EXPECT_EQ(kClassM, MDS_CULL_CLASS_M);
  EXPECT_EQ(kClassO, MDS_CULL_CLASS_O);
  EXPECT_EQ(class_letter(kClassO), 'O');
}

TEST(StreamingResidency, EvictionOrderOThenMThenLruThenFarthest) {
  ResidencyTable t(std::vector<uint64_t>(8, 100), Policy::occlusion);
  // node: class, last use, distance
  struct S { uint8_t cls; uint64_t use; float dist; };
  const S s[8] = {{kClassP, 5, 1}, {kClassO, 9, 1}, {kClassL, 3, 2}, {kClassM, 8, 1},
                  {kClassP, 3, 7}, {kClassO, 2, 3}, {kClassM, 1, 1}, {kClassL, 9, 1}};
  for (uint32_t i = 0; i < 8; ++i) {
    load(t, i);
    t.set_class(i, s[i].cls);
    t.touch(i, s[i].use);
    t.set_view(i, s[i].dist, 1.0f);
  }
  // O: 5 (use 2) before 1 (use 9); M: 6 (use 1) before 3 (use 8);
  // L/P: use 3 -> 4 (dist 7, farther) before 2 (dist 2); then 0 (use 5); then 7 (use 9).
  EXPECT_EQ(t.eviction_order(), (std::vector<uint32_t>{5, 1, 6, 3, 4, 2, 0, 7}));

  // Victims: 250 bytes needed with 0 free -> three victims; nodes drawn in frame 9 are kept
  // unless they are O (not drawn).
  auto v = t.choose_victims(250, 0, 9);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(*v, (std::vector<uint32_t>{5, 1, 6}));
  auto all = t.choose_victims(800, 0, 9);  // node 7 (L, drawn in frame 9) cannot go
  ASSERT_FALSE(all.ok());
  EXPECT_EQ(all.error().code, Errc::budget);
  EXPECT_TRUE(t.choose_victims(50, 60, 9)->empty());

  ResidencyTable lru(std::vector<uint64_t>(8, 100), Policy::lru);
  ResidencyTable fifo(std::vector<uint64_t>(8, 100), Policy::fifo);
  for (uint32_t i : {3u, 0u, 7u, 1u, 6u, 2u, 5u, 4u}) {
    load(lru, i);
    load(fifo, i);
  }
  for (uint32_t i = 0; i < 8; ++i) {
    for (ResidencyTable* x : {&lru, &fifo}) {
      x->set_class(i, s[i].cls);
      x->touch(i, s[i].use);
      x->set_view(i, s[i].dist, 1.0f);
    }
  }
  // LRU ignores classes: use 1 (6), 2 (5), 3 (4 far, 2 near), 5 (0), 8 (3), 9 (1, 7 tie dist -> index)
  EXPECT_EQ(lru.eviction_order(), (std::vector<uint32_t>{6, 5, 4, 2, 0, 3, 1, 7}));
  EXPECT_EQ(fifo.eviction_order(), (std::vector<uint32_t>{3, 0, 7, 1, 6, 2, 5, 4}));
}

TEST(StreamingResidency, NeverLoadedONeverRequested) {
  ResidencyTable t(std::vector<uint64_t>(4, 10), Policy::occlusion);
  t.set_class(0, kClassO);  // O before it was ever loaded
  t.set_class(1, kClassP);
  t.set_class(2, kClassM);
  t.set_class(3, kClassL);
  for (int frame = 0; frame < 5; ++frame) {
    for (uint32_t i : t.prefetch_order()) {
      EXPECT_NE(i, 0u);
      ASSERT_TRUE(t.mark_requested(i).ok());
      ASSERT_TRUE(t.mark_loaded(i).ok());
    }
  }
  EXPECT_FALSE(t.node(0).ever_loaded);
  EXPECT_EQ(t.node(0).residency, Residency::absent);
  EXPECT_EQ(t.never_loaded_count(), 1u);
  EXPECT_EQ(t.resident_count(), 3u);
  EXPECT_EQ(t.resident_bytes(), 30u);
  // A class-blind policy does load it.
  ResidencyTable lru(std::vector<uint64_t>(4, 10), Policy::lru);
  lru.set_class(0, kClassO);
  EXPECT_EQ(lru.prefetch_order().size(), 4u);
}

TEST(StreamingResidency, PrefetchOrderPThenLFrontToBackLargerFirst) {
  ResidencyTable t(std::vector<uint64_t>(9, 10), Policy::occlusion);
  struct S { uint8_t cls; float dist; float size; bool frustum; };
  const S s[9] = {{kClassL, 1, 1, true}, {kClassP, 5, 1, true}, {kClassP, 2, 1, true},
                  {kClassO, 0, 9, true}, {kClassP, 2, 4, true}, {kClassM, 0, 1, true},
                  {kClassL, 0.5f, 1, true}, {kClassP, 0.1f, 1, false}, {kClassP, 9, 1, true}};
  for (uint32_t i = 0; i < 9; ++i) {
    t.set_class(i, s[i].cls);
    t.set_view(i, s[i].dist, s[i].size, s[i].frustum);
  }
  // P: 4 (dist 2, size 4) before 2 (dist 2, size 1), then 1, 8; L: 6, 0; M: 5; O (3) and
  // the node outside the frustum (7) are not requested.
  EXPECT_EQ(t.prefetch_order(), (std::vector<uint32_t>{4, 2, 1, 8, 6, 0, 5}));
  EXPECT_EQ(t.prefetch_order(3), (std::vector<uint32_t>{4, 2, 1}));
  // Requested and failed nodes are not offered again.
  ASSERT_TRUE(t.mark_requested(4).ok());
  ASSERT_TRUE(t.mark_requested(2).ok());
  ASSERT_TRUE(t.mark_failed(2).ok());
  EXPECT_EQ(t.prefetch_order(2), (std::vector<uint32_t>{1, 8}));
  EXPECT_FALSE(t.mark_requested(2).ok());
  // Impossible transitions are internal errors.
  EXPECT_FALSE(t.mark_evicted(1).ok());
  EXPECT_FALSE(t.mark_loaded(1).ok());
  // New view: classes restart at P, residency stays.
  ASSERT_TRUE(t.mark_loaded(4).ok());
  t.reset_classes();
  EXPECT_EQ(t.node(3).cls, kClassP);
  EXPECT_EQ(t.node(4).residency, Residency::resident);
}

TEST(StreamingResidency, ParsesPolicies) {
  EXPECT_EQ(*parse_policy("occlusion"), Policy::occlusion);
  EXPECT_EQ(*parse_policy("lru"), Policy::lru);
  EXPECT_EQ(*parse_policy("fifo"), Policy::fifo);
  auto bad = parse_policy("random");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("random"), std::string::npos);
}

TEST(StreamingResidency, NearerNodeDisplacesFartherDrawnNodeNeverTheReverse) {
  // Three resident nodes drawn in frame 4 (P, distances 5, 9, 2) fill the pool; node 3 (P,
  // distance 3) arrives. It may replace the farther drawn nodes (0 and 1: fetched after it), never
  // node 2 (nearer); a far node 4 (distance 20) can replace nothing drawn.
  ResidencyTable t(std::vector<uint64_t>(5, 100), Policy::occlusion);
  const float dist[5] = {5, 9, 2, 3, 20};
  for (uint32_t i = 0; i < 5; ++i) t.set_view(i, dist[i], 1.0f);
  for (uint32_t i = 0; i < 3; ++i) {
    load(t, i);
    t.touch(i, 4);
  }
  EXPECT_TRUE(t.displaces(3, 1));
  EXPECT_FALSE(t.displaces(3, 2));
  EXPECT_EQ(t.evictable_bytes(4), 0u);
  EXPECT_EQ(t.evictable_bytes(4, 3), 200u);
  EXPECT_EQ(t.evictable_bytes(4, 4), 0u);
  auto v = t.choose_victims(100, 0, 4, 3);
  ASSERT_TRUE(v.ok());
  ASSERT_EQ(v->size(), 1u);
  EXPECT_NE(v->front(), 2u);
  EXPECT_FALSE(t.choose_victims(100, 0, 4, 4).ok());
  EXPECT_FALSE(t.choose_victims(100, 0, 4).ok());  // without an incoming node drawn nodes stay
}

// Look-ahead (the camera's extrapolated motion, StreamCache::set_view): nodes that stay in view
// longer are fetched first and evicted last; a node outside the frustum that the motion brings in
// is read after every wanted node, and is never demand.
TEST(StreamingResidency, LookAheadFetchesPersistentNodesFirstAndIncomingNodesLast) {
  ResidencyTable t(std::vector<uint64_t>(5, 100), Policy::occlusion);
  // node: distance, in frustum, views ahead containing it
  struct S { float dist; bool in; uint8_t ahead; };
  const S s[5] = {{1, true, 0}, {2, true, 3}, {3, true, 3}, {0.5f, false, 2}, {0.2f, false, 0}};
  for (uint32_t i = 0; i < 5; ++i) {
    t.set_view(i, s[i].dist, 1.0f, s[i].in);
    t.set_ahead(i, s[i].ahead);
    t.set_class(i, s[i].in || s[i].ahead > 0 ? kClassP : kClassO);
  }
  EXPECT_TRUE(t.wanted(0));
  EXPECT_FALSE(t.wanted(3));  // look-ahead: worth reading, not demand
  EXPECT_TRUE(t.fetchable(3));
  EXPECT_FALSE(t.fetchable(4));  // outside, and no extrapolated view brings it in
  // Wanted first, the ones staying in view (1, 2) before the one leaving (0) although it is
  // nearer; the look-ahead node 3 last although it is the nearest.
  EXPECT_EQ(t.prefetch_order(), (std::vector<uint32_t>{1, 2, 0, 3}));

  // All resident and drawn in frame 7: room for wanted node 0 may come only from drawn nodes
  // fetched after it, which leaves the look-ahead node 3 (1 and 2 are fetched before 0).
  for (uint32_t i : {0u, 1u, 2u, 3u}) {
    load(t, i);
    t.touch(i, 7);
  }
  auto v = t.choose_victims(100, 0, 7, 0);
  ASSERT_TRUE(v.ok()) << v.error().message;
  EXPECT_EQ(v.value(), (std::vector<uint32_t>{3}));
  // Among nodes drawn in the same frame, the one leaving view soonest is evicted first.
  const auto order = t.eviction_order();
  EXPECT_EQ(order.front(), 0u);
  EXPECT_EQ(order.back(), 1u);  // stays 3 views, nearer than 2
}

// Within the O group, nodes outside the view (not in the frustum, in no next view) go first: an
// occluded node in the frustum may show through a gap as the camera moves on, a node the camera
// has passed only comes back when it turns. evicted_before() ranks a node not yet resident as if
// it were placed and used in the given frame (a late arrival, StreamSettings::keep_late_arrivals).
TEST(StreamingResidency, OccludedNodesOutsideTheViewEvictedBeforeOccludedNodesInIt) {
  ResidencyTable t(std::vector<uint64_t>(6, 100), Policy::occlusion);
  // node: in frustum, ahead, last use
  struct S { bool in; uint8_t ahead; uint64_t use; };
  const S s[5] = {{true, 0, 2}, {false, 0, 9}, {false, 2, 1}, {true, 3, 5}, {false, 0, 4}};
  for (uint32_t i = 0; i < 5; ++i) {
    load(t, i);
    t.set_class(i, kClassO);
    t.touch(i, s[i].use);
    t.set_view(i, 1.0f, 1.0f, s[i].in);
    t.set_ahead(i, s[i].ahead);
  }
  // Outside the view: 4 (use 4), 1 (use 9); in it or ahead: 2 (use 1), 0 (use 2), 3 (use 5).
  EXPECT_EQ(t.eviction_order(), (std::vector<uint32_t>{4, 1, 2, 0, 3}));
  // Node 5, occluded in the frustum, arriving in frame 10: after every resident node in the view
  // used before frame 10; a node outside the view comes first whatever its last use.
  t.set_class(5, kClassO);
  t.set_view(5, 1.0f, 1.0f, true);
  for (uint32_t i = 0; i < 5; ++i) EXPECT_TRUE(t.evicted_before(i, 5, 10)) << i;
  EXPECT_FALSE(t.evicted_before(3, 5, 4));  // node 3 (used in frame 5) after a use in frame 4
  EXPECT_TRUE(t.evicted_before(1, 5, 4));   // outside the view
  // A P node in the frustum stays after every O node.
  load(t, 5);
  t.set_class(5, kClassP);
  t.touch(5, 0);
  EXPECT_EQ(t.eviction_order().back(), 5u);
}

// evictable_bytes_in_order (one sort of the drawn resident nodes, a cursor over the candidates)
// equals evictable_bytes for every candidate of the prefetch order, on random tables of every
// policy: classes, distances, sizes, look-ahead counts, frustum flags, drawn and not drawn.
TEST(StreamingResidency, EvictableBytesInOrderEqualsPerCandidate) {
  Lcg next{12345};
  for (Policy policy : {Policy::occlusion, Policy::lru, Policy::fifo}) {
    for (int trial = 0; trial < 40; ++trial) {
      const uint32_t n = 20 + next(200);
      std::vector<uint64_t> bytes(n);
      for (auto& b : bytes) b = 100 * (1 + next(8));
      ResidencyTable t(bytes, policy);
      for (uint32_t i = 0; i < n; ++i) {
        t.set_view(i, float(next(1000)) / 10.0f, float(next(100)) / 50.0f, next(5) != 0);
        t.set_class(i, uint8_t(next(4)));
        t.set_ahead(i, uint8_t(next(4)));
        if (next(3) == 0) {
          load(t, i);
          t.touch(i, next(2) == 0 ? 7 : 6);
        }
      }
      const auto order = t.prefetch_order();
      const auto fast = t.evictable_bytes_in_order(order, 7);
      ASSERT_EQ(fast.size(), order.size());
      for (size_t k = 0; k < order.size(); ++k)
        ASSERT_EQ(fast[k], t.evictable_bytes(7, order[k])) << "policy " << int(policy) << " trial " << trial << " k " << k;
    }
  }
}

TEST(StreamingResidency, ResidentListFollowsEveryTransition) {
  // resident_nodes() is kept by mark_loaded / mark_evicted (swap-remove) instead of a scan of
  // every node: after any sequence of transitions it holds exactly the resident nodes, once each,
  // and choose_victims (which walks it) picks the same victims as the sorted eviction order.
  Lcg next{777};
  const uint32_t n = 300;
  std::vector<uint64_t> bytes(n);
  for (auto& b : bytes) b = 100 * (1 + next(8));
  ResidencyTable t(bytes, Policy::occlusion);
  for (uint32_t i = 0; i < n; ++i) t.set_view(i, float(next(1000)) / 10.0f, 0.1f, true);
  for (int step = 0; step < 5000; ++step) {
    const uint32_t i = next(n);
    switch (t.node(i).residency) {
      case Residency::absent: ASSERT_TRUE(t.mark_requested(i).ok()); break;
      case Residency::requested: ASSERT_TRUE((next(4) == 0 ? t.mark_cancelled(i) : t.mark_loaded(i)).ok()); break;
      case Residency::resident:
        if (next(2) == 0) {
          ASSERT_TRUE(t.mark_evicted(i).ok());
        }
        break;
    }
    t.set_class(i, uint8_t(next(4)));
    t.touch(i, next(3));
    if (step % 97 != 0) continue;
    std::vector<uint32_t> listed(t.resident_nodes().begin(), t.resident_nodes().end()), scanned;
    uint64_t resident_bytes = 0;
    for (uint32_t k = 0; k < n; ++k)
      if (t.node(k).residency == Residency::resident) {
        scanned.push_back(k);
        resident_bytes += bytes[k];
      }
    std::sort(listed.begin(), listed.end());
    ASSERT_EQ(listed, scanned) << "step " << step;
    ASSERT_EQ(t.resident_count(), scanned.size());
    ASSERT_EQ(t.resident_bytes(), resident_bytes);
    // Victims for a need of half the resident bytes, nothing protected: a prefix of eviction_order().
    const auto order = t.eviction_order();
    auto victims = t.choose_victims(resident_bytes / 2 + 1, 0, 99);
    if (resident_bytes == 0) continue;
    ASSERT_TRUE(victims.ok());
    ASSERT_LE(victims.value().size(), order.size());
    for (size_t k = 0; k < victims.value().size(); ++k) ASSERT_EQ(victims.value()[k], order[k]) << "step " << step;
  }
}

TEST(StreamingResidency, PrefetchOrderWithALimitIsThePrefixOfTheWholeOrder) {
  // prefetch_order(limit) selects the first `limit` candidates (nth_element on precomputed keys)
  // and sorts only those: the same nodes in the same order as the whole order's prefix, which is
  // sorted by the fetch order (displaces()).
  Lcg next{4242};
  for (Policy policy : {Policy::occlusion, Policy::lru, Policy::fifo}) {
    for (int trial = 0; trial < 30; ++trial) {
      const uint32_t n = 10 + next(400);
      ResidencyTable t(std::vector<uint64_t>(n, 100), policy);
      for (uint32_t i = 0; i < n; ++i) {
        // Few distinct distances: ties decided by the later keys and the index.
        t.set_view(i, float(next(6)), float(next(4)) / 4.0f, next(4) != 0);
        t.set_class(i, uint8_t(next(4)));
        t.set_ahead(i, uint8_t(next(3)));
        if (next(5) == 0) {
          ASSERT_TRUE(t.mark_requested(i).ok());
        }
      }
      const auto whole = t.prefetch_order();
      for (size_t k = 1; k < whole.size(); ++k) ASSERT_TRUE(t.displaces(whole[k - 1], whole[k])) << k;
      for (size_t limit : {size_t(0), size_t(1), size_t(7), whole.size() / 2, whole.size(), whole.size() + 3}) {
        const auto part = t.prefetch_order(limit);
        ASSERT_EQ(part.size(), std::min(limit, whole.size()));
        ASSERT_TRUE(std::equal(part.begin(), part.end(), whole.begin())) << "limit " << limit << " trial " << trial;
      }
    }
  }
}

// A node's bytes, learnt when it was read (--slice thins a node): the resident total and the
// victims follow the new size; a resident node's size cannot change.
TEST(StreamingResidency, BytesOfANodeReadSmallerThanPlanned) {
  ResidencyTable t(std::vector<uint64_t>{100, 100, 100}, Policy::occlusion);
  ASSERT_TRUE(t.mark_requested(1).ok());
  ASSERT_TRUE(t.set_bytes(1, 30).ok());  // read: it keeps less than its directory entry
  ASSERT_TRUE(t.mark_loaded(1).ok());
  load(t, 0);
  EXPECT_EQ(t.resident_bytes(), 130u);
  EXPECT_EQ(t.set_bytes(1, 10).error().code, Errc::internal);  // resident
  // 120 bytes with none free: node 1 frees only 30 now, so both go.
  t.set_class(0, kClassO);
  t.set_class(1, kClassO);
  auto v = t.choose_victims(120, 0, 5);
  ASSERT_TRUE(v.ok()) << v.error().message;
  EXPECT_EQ(v->size(), 2u);
  ASSERT_TRUE(t.mark_evicted(1).ok());
  EXPECT_EQ(t.resident_bytes(), 100u);
  EXPECT_EQ(t.set_bytes(9, 1).error().code, Errc::internal);  // out of range
}
