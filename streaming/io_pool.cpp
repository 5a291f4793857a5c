// See io_pool.h (Ibrahim et al. §8; Grottel et al. §3.1/§3.3: the render loop never waits on I/O).
#include "streaming/io_pool.h"

#include <chrono>
#include <cmath>

namespace mds::streaming {

Result<std::unique_ptr<IoPool>> IoPool::create(const store::StoreReader& reader, const IoOptions& options) {
  if (options.threads == 0 || options.threads > 256)
    return make_error(Errc::invalid_argument, "I/O threads must be in 1..256, got {}", options.threads);
  if (!(options.io_latency_ms >= 0) || !std::isfinite(options.io_latency_ms))
    return make_error(Errc::invalid_argument, "io_latency_ms must be >= 0, got {}", options.io_latency_ms);
  if (!(options.io_bandwidth >= 0) || !std::isfinite(options.io_bandwidth))
    return make_error(Errc::invalid_argument, "io_bandwidth must be >= 0 bytes/s (0 = unlimited), got {}", options.io_bandwidth);
  return std::unique_ptr<IoPool>(new IoPool(reader, options));
}

IoPool::IoPool(const store::StoreReader& reader, const IoOptions& options)
    : reader_(reader), options_(options), paused_(options.start_paused) {
  threads_.reserve(options.threads);
  for (unsigned i = 0; i < options.threads; ++i) threads_.emplace_back([this] { worker(); });
}

IoPool::~IoPool() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    queue_.clear();
    queued_.clear();
  }
  work_cv_.notify_all();
  delay_cv_.notify_all();
  for (auto& t : threads_) t.join();
}

int IoPool::submit_locked(uint32_t node, double priority) {
  if (stop_ || node >= reader_.nodes().size() || failed_.count(node) || busy_.count(node)) return 0;
  if (auto it = queued_.find(node); it != queued_.end()) {
    queue_.erase(it->second);
    it->second = Key{priority, seq_++, node};
    queue_.insert(it->second);
    return 2;
  }
  Key k{priority, seq_++, node};
  queue_.insert(k);
  queued_.emplace(node, k);
  ++stats_.submitted;
  return 1;
}

bool IoPool::submit(uint32_t node, double priority) {
  int r;
  {
    std::lock_guard lock(mutex_);
    r = submit_locked(node, priority);
  }
  if (r == 1) work_cv_.notify_one();
  return r != 0;
}

bool IoPool::Batch::submit(uint32_t node, double priority) {
  const int r = pool_.submit_locked(node, priority);
  if (r == 1) ++added_;
  return r != 0;
}

IoPool::Batch::~Batch() {
  lock_.unlock();
  if (added_ == 1) pool_.work_cv_.notify_one();
  else if (added_ > 1) pool_.work_cv_.notify_all();
}

void IoPool::resume() {
  {
    std::lock_guard lock(mutex_);
    paused_ = false;
  }
  work_cv_.notify_all();
}

bool IoPool::cancel(uint32_t node) {
  std::lock_guard lock(mutex_);
  auto it = queued_.find(node);
  if (it == queued_.end()) return false;
  queue_.erase(it->second);
  queued_.erase(it);
  ++stats_.cancelled;
  if (queue_.empty() && busy_.empty()) idle_cv_.notify_all();
  return true;
}

size_t IoPool::cancel_all() {
  std::lock_guard lock(mutex_);
  const size_t n = queue_.size();
  queue_.clear();
  queued_.clear();
  stats_.cancelled += n;
  idle_cv_.notify_all();
  return n;
}

std::optional<IoCompletion> IoPool::try_pop() {
  std::optional<IoCompletion> out;
  {
    std::lock_guard lock(done_mutex_);
    if (done_.empty()) return std::nullopt;
    out = std::move(done_.front());
    done_.pop_front();
  }
  std::lock_guard lock(mutex_);
  busy_.erase(out->node);
  idle_cv_.notify_all();
  return out;
}

void IoPool::wait_idle() {
  // "Idle" = nothing queued and no read running; finished results may still wait in the
  // completion queue (they are counted in busy_ until popped, so wait on running reads only).
  std::unique_lock lock(mutex_);
  idle_cv_.wait(lock, [&] {
    if (!queue_.empty()) return false;
    std::lock_guard dl(done_mutex_);
    return busy_.size() == done_.size();
  });
}

bool IoPool::is_failed(uint32_t node) const {
  std::lock_guard lock(mutex_);
  return failed_.count(node) != 0;
}

size_t IoPool::queued() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

size_t IoPool::in_flight() const {
  std::lock_guard lock(mutex_);
  return busy_.size();
}

IoStats IoPool::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void IoPool::simulate_delay(uint64_t bytes) {
  double seconds = options_.io_latency_ms / 1000.0;
  if (options_.io_bandwidth > 0) seconds += double(bytes) / options_.io_bandwidth;
  if (seconds <= 0) return;
  std::unique_lock lock(mutex_);
  delay_cv_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return stop_; });
}

void IoPool::worker() {
  std::vector<uint8_t> compressed;
  for (;;) {
    uint32_t node = 0;
    {
      std::unique_lock lock(mutex_);
      work_cv_.wait(lock, [&] { return stop_ || (!paused_ && !queue_.empty()); });
      if (stop_) return;
      node = std::get<2>(*queue_.begin());
      queue_.erase(queue_.begin());
      queued_.erase(node);
      busy_.insert(node);
    }
    IoCompletion c;
    c.node = node;
    const store::NodeEntry& e = reader_.nodes()[node];
    simulate_delay(e.payload_bytes);
    c.status = reader_.read_payload(node, compressed);
    if (c.status.ok()) c.status = reader_.decode_payload(node, compressed, c.data);
    if (c.status.ok() && options_.prepare) {
      Status st = options_.prepare(node, c.data, c.prepared);
      if (!st.ok())
        c.status = make_error(st.error().code, "{}: {}", reader_.path().string(), st.error().message);
    }
    if (c.status.ok()) {
      c.compressed_bytes = e.payload_bytes;
      c.raw_bytes = e.payload_raw_bytes;
    } else {
      c.data = store::NodeData{};
      c.prepared = PreparedNode{};
    }
    {
      std::lock_guard lock(mutex_);
      if (c.status.ok()) {
        ++stats_.completed;
        stats_.bytes_read += e.payload_bytes;
      } else {
        ++stats_.failed;
        failed_.insert(node);
      }
      std::lock_guard dl(done_mutex_);
      done_.push_back(std::move(c));
    }
    idle_cv_.notify_all();
  }
}

}  // namespace mds::streaming
