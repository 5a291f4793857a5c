// See belady.h (Belady's MIN, farthest-next-use eviction; variable sizes: heuristic reference).
#include "streaming/belady.h"

#include <limits>
#include <list>
#include <set>
#include <unordered_map>
#include <utility>

namespace mds::streaming {

namespace {

constexpr uint64_t kNever = std::numeric_limits<uint64_t>::max();

// Size per node = bytes of its first request.
std::unordered_map<uint32_t, uint64_t> node_sizes(std::span<const TraceRequest> trace) {
  std::unordered_map<uint32_t, uint64_t> sizes;
  for (const auto& r : trace) sizes.emplace(r.node, r.bytes);
  return sizes;
}

}  // namespace

CacheSimResult simulate_belady(std::span<const TraceRequest> trace, uint64_t budget_bytes, bool allow_bypass,
                               std::vector<uint8_t>* hit_out) {
  CacheSimResult res;
  if (hit_out) hit_out->assign(trace.size(), 0);
  const auto sizes = node_sizes(trace);
  // next[i] = index of the next request of trace[i].node after i, kNever if none.
  std::vector<uint64_t> next(trace.size(), kNever);
  {
    std::unordered_map<uint32_t, uint64_t> seen;
    for (size_t i = trace.size(); i-- > 0;) {
      auto it = seen.find(trace[i].node);
      if (it != seen.end()) next[i] = it->second;
      seen[trace[i].node] = i;
    }
  }
  // Resident nodes ordered by next use, farthest last; map node -> its key.
  std::set<std::pair<uint64_t, uint32_t>> by_next;
  std::unordered_map<uint32_t, uint64_t> resident;
  uint64_t used = 0;
  for (size_t i = 0; i < trace.size(); ++i) {
    const uint32_t node = trace[i].node;
    const uint64_t size = sizes.at(node);
    ++res.requests;
    res.bytes_requested += size;
    if (auto it = resident.find(node); it != resident.end()) {
      ++res.hits;
      res.bytes_hit += size;
      if (hit_out) (*hit_out)[i] = 1;
      by_next.erase({it->second, node});
      it->second = next[i];
      by_next.insert({next[i], node});
      continue;
    }
    if (size > budget_bytes) continue;  // can never be cached
    if (allow_bypass && next[i] == kNever) continue;  // never reused: not worth caching
    // Bypass: room must come from residents used later than the incoming node (farthest first);
    // if those do not free enough, the incoming node is the one to drop (nothing evicted).
    if (allow_bypass && used + size > budget_bytes) {
      uint64_t freeable = budget_bytes - used;
      for (auto it = by_next.rbegin(); it != by_next.rend() && it->first > next[i] && freeable < size; ++it)
        freeable += sizes.at(it->second);
      if (freeable < size) continue;
    }
    while (used + size > budget_bytes) {
      auto far = std::prev(by_next.end());
      used -= sizes.at(far->second);
      resident.erase(far->second);
      by_next.erase(far);
      ++res.evictions;
    }
    resident.emplace(node, next[i]);
    by_next.insert({next[i], node});
    used += size;
  }
  return res;
}

namespace {

// Shared LRU/FIFO simulation: `touch_on_hit` moves a hit to the back (LRU); FIFO keeps order.
CacheSimResult simulate_list(std::span<const TraceRequest> trace, uint64_t budget_bytes, bool touch_on_hit) {
  CacheSimResult res;
  const auto sizes = node_sizes(trace);
  std::list<uint32_t> order;  // front = evicted first
  std::unordered_map<uint32_t, std::list<uint32_t>::iterator> resident;
  uint64_t used = 0;
  for (const auto& r : trace) {
    const uint64_t size = sizes.at(r.node);
    ++res.requests;
    res.bytes_requested += size;
    if (auto it = resident.find(r.node); it != resident.end()) {
      ++res.hits;
      res.bytes_hit += size;
      if (touch_on_hit) order.splice(order.end(), order, it->second);
      continue;
    }
    if (size > budget_bytes) continue;
    while (used + size > budget_bytes) {
      const uint32_t victim = order.front();
      order.pop_front();
      resident.erase(victim);
      used -= sizes.at(victim);
      ++res.evictions;
    }
    order.push_back(r.node);
    resident.emplace(r.node, std::prev(order.end()));
    used += size;
  }
  return res;
}

}  // namespace

CacheSimResult simulate_lru(std::span<const TraceRequest> trace, uint64_t budget_bytes) { return simulate_list(trace, budget_bytes, true); }
CacheSimResult simulate_fifo(std::span<const TraceRequest> trace, uint64_t budget_bytes) { return simulate_list(trace, budget_bytes, false); }

}  // namespace mds::streaming
