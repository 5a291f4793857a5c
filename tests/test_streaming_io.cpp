// Tests of streaming/io_pool.h on real stores written with store::StoreWriter: every node read
// by background threads equals StoreReader::read_node; a corrupted payload gives exactly one
// error completion naming the node; the readers' prepare step; cancellation; shutdown with work
// pending.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <thread>

#include "store/store_reader.h"
#include "store_test_helpers.h"
#include "streaming/io_pool.h"

using namespace mds;
using namespace mds::streaming;

namespace {

std::unique_ptr<store::StoreReader> make_store(const std::filesystem::path& path, uint64_t seed, size_t particles) {
  mds::testing::SynthOptions o;
  o.seed = seed;
  o.particles = particles;
  o.node_size = 64;
  o.meshlet_size = 16;
  o.per_particle_radius = seed % 2 == 0;
  auto s = mds::testing::make_synthetic(o);
  std::string err = mds::testing::write_store(s, path);
  EXPECT_EQ(err, "");
  auto r = store::StoreReader::open(path);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(r).value() : nullptr;
}

// Drains completions until `count` arrived (polling, as the render thread does).
std::vector<IoCompletion> drain(IoPool& pool, size_t count) {
  std::vector<IoCompletion> out;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (out.size() < count && std::chrono::steady_clock::now() < deadline) {
    if (auto c = pool.try_pop()) {
      out.push_back(std::move(*c));
    } else {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  return out;
}

void expect_equal(const store::NodeData& a, const store::NodeData& b, uint32_t node) {
  EXPECT_EQ(a.qpos, b.qpos) << "node " << node;
  EXPECT_EQ(a.type_index, b.type_index) << "node " << node;
  EXPECT_EQ(a.radius_q, b.radius_q) << "node " << node;
  EXPECT_EQ(a.meshlet_size, b.meshlet_size) << "node " << node;
}

}  // namespace

TEST(StreamingIo, ReadsEveryNodeLikeReadNode) {
  auto dir = mds::testing::temp_dir("streaming_io", true);
  for (unsigned threads : {1u, 3u, 4u}) {
    auto reader = make_store(dir / ("s" + std::to_string(threads) + ".mds"), threads, 3000);
    ASSERT_TRUE(reader);
    const uint32_t n = uint32_t(reader->nodes().size());
    ASSERT_GT(n, 20u);
    IoOptions opt;
    opt.threads = threads;
    opt.io_latency_ms = 1.0;
    opt.io_bandwidth = 50e6;
    auto pool = IoPool::create(*reader, opt);
    ASSERT_TRUE(pool.ok());
    for (uint32_t i = 0; i < n; ++i) EXPECT_TRUE((*pool)->submit(n - 1 - i, double(i)));
    auto done = drain(**pool, n);
    ASSERT_EQ(done.size(), n);
    EXPECT_FALSE((*pool)->try_pop().has_value());
    std::map<uint32_t, int> seen;
    store::NodeData ref;
    std::vector<uint8_t> scratch;
    uint64_t bytes = 0;
    for (const auto& c : done) {
      ASSERT_TRUE(c.status.ok()) << c.status.error().message;
      ++seen[c.node];
      ASSERT_TRUE(reader->read_node(c.node, ref, scratch).ok());
      expect_equal(c.data, ref, c.node);
      EXPECT_EQ(c.compressed_bytes, reader->nodes()[c.node].payload_bytes);
      bytes += c.compressed_bytes;
    }
    EXPECT_EQ(seen.size(), n);
    auto st = (*pool)->stats();
    EXPECT_EQ(st.completed, n);
    EXPECT_EQ(st.failed, 0u);
    EXPECT_EQ(st.bytes_read, bytes);
    EXPECT_EQ(st.bytes_read, reader->header().payload_bytes);
  }
  std::filesystem::remove_all(dir);
}

TEST(StreamingIo, PriorityOrderWithOneThread) {
  auto dir = mds::testing::temp_dir("streaming_io_prio", true);
  auto reader = make_store(dir / "p.mds", 4, 1000);
  ASSERT_TRUE(reader);
  const uint32_t n = uint32_t(reader->nodes().size());
  IoOptions opt;
  opt.threads = 1;
  opt.start_paused = true;  // queue everything first, then let the single worker run
  auto pool = IoPool::create(*reader, opt);
  ASSERT_TRUE(pool.ok());
  auto key = [](uint32_t i) { return double(i % 5) * 100.0 + double(i); };
  for (uint32_t i = 0; i < n; ++i) ASSERT_TRUE((*pool)->submit(i, 1e9));
  for (uint32_t i = 0; i < n; ++i) ASSERT_TRUE((*pool)->submit(i, key(i)));  // re-prioritised
  EXPECT_EQ((*pool)->queued(), n);
  EXPECT_EQ((*pool)->stats().submitted, n);
  (*pool)->resume();
  (*pool)->wait_idle();
  EXPECT_FALSE((*pool)->submit(0, 0.0));  // result still waiting to be popped: not read twice
  auto done = drain(**pool, n);
  ASSERT_EQ(done.size(), n);
  for (size_t k = 1; k < done.size(); ++k) {
    EXPECT_LT(key(done[k - 1].node), key(done[k].node));
  }
  std::filesystem::remove_all(dir);
}

// IoPool::Batch queues like submit() (new, re-prioritised, refused) and wakes the sleeping
// workers once it ends: without that wake the reads below would never start.
TEST(StreamingIo, BatchQueuesLikeSubmitAndWakesTheWorkersAtItsEnd) {
  auto dir = mds::testing::temp_dir("streaming_io_batch", true);
  auto reader = make_store(dir / "b.mds", 4, 1000);
  ASSERT_TRUE(reader);
  const uint32_t n = uint32_t(reader->nodes().size());
  ASSERT_GT(n, 8u);
  {
    IoOptions opt;
    opt.threads = 1;
    opt.start_paused = true;
    auto pool = IoPool::create(*reader, opt);
    ASSERT_TRUE(pool.ok());
    auto key = [](uint32_t i) { return double(i % 3) * 1000.0 + double(i); };
    {
      IoPool::Batch batch(**pool);
      for (uint32_t i = 0; i < n; ++i) ASSERT_TRUE(batch.submit(i, 1e9));
      for (uint32_t i = 0; i < n; ++i) ASSERT_TRUE(batch.submit(i, key(i)));  // re-prioritised
      EXPECT_FALSE(batch.submit(n, 0.0));                                      // no such node
    }
    EXPECT_EQ((*pool)->queued(), n);
    EXPECT_EQ((*pool)->stats().submitted, n);
    (*pool)->resume();
    auto done = drain(**pool, n);
    ASSERT_EQ(done.size(), n);
    for (size_t k = 1; k < done.size(); ++k) EXPECT_LT(key(done[k - 1].node), key(done[k].node));
  }
  for (const uint32_t count : {1u, n}) {  // one request (notify_one) and many (notify_all)
    IoOptions opt;
    opt.threads = 3;
    auto pool = IoPool::create(*reader, opt);
    ASSERT_TRUE(pool.ok());
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the workers are asleep by then
    {
      IoPool::Batch batch(**pool);
      for (uint32_t i = 0; i < count; ++i) ASSERT_TRUE(batch.submit(i, double(i)));
    }
    auto done = drain(**pool, count);
    ASSERT_EQ(done.size(), count);
    for (const auto& c : done) EXPECT_TRUE(c.status.ok());
  }
  std::filesystem::remove_all(dir);
}

TEST(StreamingIo, CorruptedPayloadReportedOnceNeverRetried) {
  auto dir = mds::testing::temp_dir("streaming_io_corrupt", true);
  const auto path = dir / "c.mds";
  auto reader0 = make_store(path, 6, 2000);
  ASSERT_TRUE(reader0);
  const uint32_t bad = uint32_t(reader0->nodes().size() / 2);
  const uint64_t off = reader0->nodes()[bad].payload_offset + reader0->nodes()[bad].payload_bytes / 2;
  reader0.reset();
  auto bytes = mds::testing::read_bytes(path);
  bytes[off] ^= 0x5a;
  mds::testing::write_bytes(path, bytes);
  auto opened = store::StoreReader::open(path);
  ASSERT_TRUE(opened.ok());
  auto& reader = *opened;
  const uint32_t n = uint32_t(reader->nodes().size());

  IoOptions opt;
  opt.threads = 3;
  auto pool = IoPool::create(*reader, opt);
  ASSERT_TRUE(pool.ok());
  for (uint32_t i = 0; i < n; ++i) ASSERT_TRUE((*pool)->submit(i, 0.0));
  auto done = drain(**pool, n);
  ASSERT_EQ(done.size(), n);
  int errors = 0;
  for (const auto& c : done) {
    if (c.node == bad) {
      ASSERT_FALSE(c.status.ok());
      ++errors;
      const auto& e = c.status.error();
      EXPECT_EQ(e.code, Errc::checksum);
      EXPECT_NE(e.message.find(path.filename().string()), std::string::npos) << e.message;
      EXPECT_NE(e.message.find(std::to_string(bad)), std::string::npos) << e.message;
      EXPECT_NE(e.message.find(std::to_string(reader->nodes()[bad].payload_offset)), std::string::npos) << e.message;
      EXPECT_EQ(c.data.particle_count(), 0u);
    } else {
      EXPECT_TRUE(c.status.ok()) << c.status.error().message;
      EXPECT_EQ(c.data.particle_count(), reader->nodes()[c.node].particle_count);
    }
  }
  EXPECT_EQ(errors, 1);
  EXPECT_TRUE((*pool)->is_failed(bad));
  // Never retried: a new request for the bad node is refused; good nodes can be read again.
  EXPECT_FALSE((*pool)->submit(bad, 0.0));
  EXPECT_TRUE((*pool)->submit(0, 0.0));
  auto again = drain(**pool, 1);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_TRUE(again[0].status.ok());
  EXPECT_EQ((*pool)->stats().failed, 1u);
  std::filesystem::remove_all(dir);
}

// IoOptions::prepare runs on the reader threads, once per decoded node, and its output arrives
// with the node; an error from it fails the node like a bad payload (named with the store's
// path, reported once, never read again).
TEST(StreamingIo, PrepareRunsOnTheReaderThreads) {
  auto dir = mds::testing::temp_dir("streaming_io_prepare", true);
  const auto path = dir / "p.mds";
  auto reader = make_store(path, 8, 2000);
  ASSERT_TRUE(reader);
  const uint32_t n = uint32_t(reader->nodes().size());
  const uint32_t bad = n / 3;
  const std::thread::id caller = std::this_thread::get_id();
  std::atomic<int> on_caller{0}, calls{0};
  IoOptions opt;
  opt.threads = 3;
  opt.prepare = [&](uint32_t node, const store::NodeData& d, PreparedNode& out) -> Status {
    ++calls;
    if (std::this_thread::get_id() == caller) ++on_caller;
    if (node == bad) return make_error(Errc::format, "node {}: refused", node);
    out.meshlet_bounds.assign({float(node), float(d.particle_count()), float(d.meshlet_size.size())});
    return {};
  };
  auto pool = IoPool::create(*reader, opt);
  ASSERT_TRUE(pool.ok());
  for (uint32_t i = 0; i < n; ++i) ASSERT_TRUE((*pool)->submit(i, 0.0));
  auto done = drain(**pool, n);
  ASSERT_EQ(done.size(), n);
  for (const auto& c : done) {
    if (c.node == bad) {
      ASSERT_FALSE(c.status.ok());
      EXPECT_EQ(c.status.error().code, Errc::format);
      EXPECT_NE(c.status.error().message.find(path.filename().string()), std::string::npos) << c.status.error().message;
      EXPECT_NE(c.status.error().message.find("refused"), std::string::npos) << c.status.error().message;
      EXPECT_TRUE(c.prepared.empty());
      EXPECT_EQ(c.data.particle_count(), 0u);
      continue;
    }
    ASSERT_TRUE(c.status.ok()) << c.status.error().message;
    const auto& e = reader->nodes()[c.node];
    ASSERT_EQ(c.prepared.meshlet_bounds.size(), 3u);
    EXPECT_EQ(c.prepared.meshlet_bounds[0], float(c.node));
    EXPECT_EQ(c.prepared.meshlet_bounds[1], float(e.particle_count));
    EXPECT_EQ(c.prepared.meshlet_bounds[2], float(e.meshlet_count));
  }
  EXPECT_EQ(calls.load(), int(n));
  EXPECT_EQ(on_caller.load(), 0);
  EXPECT_TRUE((*pool)->is_failed(bad));
  EXPECT_FALSE((*pool)->submit(bad, 0.0));
  EXPECT_EQ((*pool)->stats().failed, 1u);
  pool->reset();
  std::filesystem::remove_all(dir);
}

TEST(StreamingIo, CancelAndShutdownWithPendingWork) {
  auto dir = mds::testing::temp_dir("streaming_io_cancel", true);
  auto reader = make_store(dir / "x.mds", 8, 2000);
  ASSERT_TRUE(reader);
  const uint32_t n = uint32_t(reader->nodes().size());
  {
    IoOptions opt;
    opt.threads = 2;
    opt.io_latency_ms = 30;
    auto pool = IoPool::create(*reader, opt);
    ASSERT_TRUE(pool.ok());
    for (uint32_t i = 0; i < n; ++i) ASSERT_TRUE((*pool)->submit(i, double(i)));
    EXPECT_TRUE((*pool)->cancel(n - 1));
    EXPECT_FALSE((*pool)->cancel(n - 1));
    const size_t rest = (*pool)->cancel_all();
    EXPECT_GE(rest + 2, size_t(n - 1));  // at most two already started
    (*pool)->wait_idle();
    std::vector<IoCompletion> done;
    while (auto c = (*pool)->try_pop()) done.push_back(std::move(*c));
    EXPECT_LE(done.size(), 2u);
    for (const auto& c : done) EXPECT_TRUE(c.status.ok());
    EXPECT_EQ((*pool)->stats().cancelled, rest + 1);
    // Leave more work queued and in flight: the destructor stops and joins promptly.
    for (uint32_t i = 0; i < n; ++i) (*pool)->submit(i, 0.0);
  }
  IoOptions bad;
  bad.threads = 0;
  EXPECT_FALSE(IoPool::create(*reader, bad).ok());
  bad.threads = 1;
  bad.io_bandwidth = -1;
  EXPECT_FALSE(IoPool::create(*reader, bad).ok());
  std::filesystem::remove_all(dir);
}
