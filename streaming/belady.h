// Offline Belady-optimal (MIN) hit rate of a recorded request trace under a byte budget, as the
// bound the stress tests compare the online cache policies against (issue 4, `mdstream stress`).
// Belady 1966: on a miss, evict the resident object whose next use is farthest in the future.
// Default (demand) mode: every requested object is loaded, as a node must be resident on the
// device to be drawn; for unit sizes this is the textbook MIN / OPT and its hit count is optimal.
// With allow_bypass the incoming object takes part in the choice (it is not cached when its own
// next use is the farthest); for unit sizes that is optimal among policies that may bypass.
// With variable sizes, optimal caching is NP-hard; the farthest-next-use rule is then a strong
// heuristic reference, NOT a proven bound (a policy can beat it on some traces).
// Objects larger than the budget are never cached (always a miss). O(n log n) for unit sizes;
// with variable sizes and bypass the check scans the residents used later than the incoming one.
// LRU and FIFO simulations with the same byte semantics are provided for comparison.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace mds::streaming {

struct TraceRequest {
  uint32_t node = 0;
  uint64_t bytes = 0;  // size of the node (taken from its first request if it varies)
};

struct CacheSimResult {
  uint64_t requests = 0;
  uint64_t hits = 0;
  uint64_t bytes_requested = 0;
  uint64_t bytes_hit = 0;
  uint64_t evictions = 0;
  double hit_rate() const { return requests ? double(hits) / double(requests) : 0.0; }
  double byte_hit_rate() const { return bytes_requested ? double(bytes_hit) / double(bytes_requested) : 0.0; }
};

// hit_out (optional): set to one entry per request, 1 where that request was a hit (the
// per-request outcome that `stress --trace` writes next to the online cache's).
CacheSimResult simulate_belady(std::span<const TraceRequest> trace, uint64_t budget_bytes, bool allow_bypass = false,
                               std::vector<uint8_t>* hit_out = nullptr);
CacheSimResult simulate_lru(std::span<const TraceRequest> trace, uint64_t budget_bytes);
CacheSimResult simulate_fifo(std::span<const TraceRequest> trace, uint64_t budget_bytes);

}  // namespace mds::streaming
