// Asynchronous node reads for the streaming cache (issue 4, "Asynchronous I/O").
// Follows Ibrahim et al. §8 (out-of-core future work) and Grottel et al. §3.1/§3.3: the render
// loop never blocks on disk. Background reader threads take node requests in priority order
// (smallest key first, FIFO among equal keys), read the payload with StoreReader::read_payload
// (XXH3 checksum verified), lz4-decode it with StoreReader::decode_payload and push the decoded
// node to a completion queue that the render thread polls with try_pop() (never waits for I/O).
// A node whose read or decode fails is reported once, as an error completion naming the file,
// node and byte offset, and is never read again. Queued requests can be cancelled. Simulated
// latency and bandwidth per request (io_latency_ms, io_bandwidth) slow reads down for stress tests.
// The destructor stops the threads (interrupting simulated waits) and joins them.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/result.h"
#include "store/store_reader.h"

namespace mds::streaming {

// What IoOptions::prepare makes of a decoded node on a reader thread for the render loop's
// upload (render/streaming/node_pool.h): its meshlet bounds and its particles in the pool's
// layout, so that placing a node is a copy.
struct PreparedNode {
  std::vector<float> meshlet_bounds;  // 6 per meshlet (min xyz, max xyz)
  std::vector<uint16_t> particles;    // 4 per particle: x, y, z, type (the pool's particle record)
  bool empty() const { return meshlet_bounds.empty() && particles.empty(); }
};

struct IoOptions {
  unsigned threads = 2;
  double io_latency_ms = 0;  // simulated per-request latency
  double io_bandwidth = 0;   // simulated bytes/s per request (compressed bytes), 0 = unlimited
  bool start_paused = false; // workers take no request until resume() (batch submission)
  // Work on a decoded node that the reader thread does before it reports the node finished
  // (the cache's meshlet bounds and particle records, render/streaming/node_pool.h
  // meshlet_bounds, pack_particles), so that the render loop does not: fills IoCompletion::prepared. Runs on the reader threads, concurrently: it
  // must only read shared state. It may change the node's data (the cache leaves out the
  // particles that --slice cuts away; IoCompletion::data is then what it made). An error makes
  // the completion an error (prefixed with the store's path), and the node is never read again,
  // as after a failed decode. Empty: none.
  std::function<Status(uint32_t node, store::NodeData& data, PreparedNode& out)> prepare;
};

struct IoCompletion {
  uint32_t node = 0;
  Status status;              // error: Errc::checksum / io / format naming file, node, offset
  store::NodeData data;       // decoded node, as IoOptions::prepare left it (empty on error)
  PreparedNode prepared;       // IoOptions::prepare's output (empty without it or on error)
  uint64_t compressed_bytes = 0;
  uint64_t raw_bytes = 0;
};

struct IoStats {
  uint64_t submitted = 0;
  uint64_t completed = 0;     // successful reads
  uint64_t failed = 0;        // error completions (one per bad node)
  uint64_t cancelled = 0;
  uint64_t bytes_read = 0;    // compressed bytes read from the file
};

class IoPool {
 public:
  // `reader` must outlive the pool. Errc::invalid_argument for bad options.
  static Result<std::unique_ptr<IoPool>> create(const store::StoreReader& reader, const IoOptions& options);
  ~IoPool();
  IoPool(const IoPool&) = delete;
  IoPool& operator=(const IoPool&) = delete;

  // Queues node `node` with priority key `priority` (smaller = sooner). A node already queued
  // gets the new priority; a node in flight, or whose result is waiting in the completion
  // queue, is not queued again. Returns false (nothing queued) for such nodes, for nodes that
  // failed before (never retried), for out-of-range nodes and after shutdown.
  bool submit(uint32_t node, double priority);

  // Several submits under one lock, the workers woken once when the batch ends: a plan that
  // queues dozens of reads wakes the readers once, not after every request (each wake had the
  // woken reader block on the lock that submit() still held: about 10 us a request on the
  // 2-core VM while a frame queued 52). Precondition: while a Batch lives, its thread makes no
  // other call on the pool (it holds the pool's lock). Not movable: make one with
  // `IoPool::Batch b(pool);`.
  class Batch {
   public:
    explicit Batch(IoPool& pool) : pool_(pool), lock_(pool.mutex_) {}
    ~Batch();  // unlocks, then wakes the workers if a request was queued
    Batch(const Batch&) = delete;
    Batch& operator=(const Batch&) = delete;
    // As IoPool::submit.
    bool submit(uint32_t node, double priority);

   private:
    IoPool& pool_;
    std::unique_lock<std::mutex> lock_;
    size_t added_ = 0;  // new requests (not re-prioritised ones)
  };

  // Removes a queued (not yet started) request. Returns true if it was queued.
  bool cancel(uint32_t node);
  // Cancels every queued request; returns how many.
  size_t cancel_all();
  // Next finished node, if any. Never waits for I/O.
  std::optional<IoCompletion> try_pop();
  // Lets the workers start taking requests (after start_paused).
  void resume();
  // Blocks until nothing is queued or in flight (for tests and headless convergence); while
  // paused with requests queued it waits for resume().
  void wait_idle();

  bool is_failed(uint32_t node) const;
  size_t queued() const;
  size_t in_flight() const;
  IoStats stats() const;

 private:
  IoPool(const store::StoreReader& reader, const IoOptions& options);
  // submit()'s work under mutex_: 0 = refused, 1 = queued, 2 = re-prioritised.
  int submit_locked(uint32_t node, double priority);
  void worker();
  void simulate_delay(uint64_t bytes);

  const store::StoreReader& reader_;
  IoOptions options_;

  mutable std::mutex mutex_;               // requests, in-flight set, failed set, stats
  std::condition_variable work_cv_;        // workers wait for requests / stop
  std::condition_variable delay_cv_;       // simulated delays wait for stop (not on work_cv_: a
                                           // notify_one for a new request must reach an idle worker)
  std::condition_variable idle_cv_;        // wait_idle
  bool stop_ = false;
  bool paused_ = false;
  uint64_t seq_ = 0;
  using Key = std::tuple<double, uint64_t, uint32_t>;  // priority, sequence, node
  std::set<Key> queue_;
  std::unordered_map<uint32_t, Key> queued_;
  std::unordered_set<uint32_t> busy_;      // in flight or waiting in the completion queue
  std::unordered_set<uint32_t> failed_;
  IoStats stats_;

  std::mutex done_mutex_;                  // completion queue only (O(1) critical sections)
  std::deque<IoCompletion> done_;

  std::vector<std::thread> threads_;
};

}  // namespace mds::streaming
