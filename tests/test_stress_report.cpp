// The report logic of `mdstream stress` (cli/vulkan/stress_report.h) on constructed inputs:
// quantiles, views and their convergence, the offline Belady/LRU/FIFO bound, the CSV flattening.
// The CLI end to end: test_stress_cli.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/vulkan/stress_report.h"

using namespace mds;
using namespace mds::cli::stress;

TEST(StressReport, Quantiles) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);  // unsorted input
  Quantiles q = quantiles(v);
  EXPECT_EQ(q.n, 100u);
  EXPECT_DOUBLE_EQ(q.p50, 50.5);    // linear interpolation between 50 and 51
  EXPECT_DOUBLE_EQ(q.p99, 99.01);   // 99 + 0.01 * (100 - 99)
  EXPECT_DOUBLE_EQ(q.max, 100.0);
  EXPECT_DOUBLE_EQ(q.ratio(), 99.01 / 50.5);
  EXPECT_DOUBLE_EQ(quantile({7.0}, 0.99), 7.0);
  EXPECT_EQ(quantiles({}).n, 0u);
  EXPECT_EQ(quantiles({}).ratio(), 0.0);
}

TEST(StressReport, ViewsAndConvergence) {
  // view 0: 3 frames, converges at its 2nd; frames 3..5: camera motion (one frame per view);
  // view 4: held, never converges; view 5: the final view, converges at its 3rd frame (a settle
  // frame), then two after-convergence frames that do not count.
  std::vector<FrameRecord> f;
  auto add = [&](uint32_t view, double ms, bool conv, uint64_t read_total, bool settle = false, bool after = false) {
    FrameRecord r;
    r.view = view;
    r.wall_ms = ms;
    r.converged = conv;
    r.bytes_read_total = read_total;
    r.settle = settle;
    r.after_converged = after;
    r.wanted_nodes = 3;
    r.wanted_payload_bytes = 300;
    f.push_back(r);
  };
  add(0, 10, false, 100);
  add(0, 20, true, 150);
  add(0, 5, true, 150);
  add(1, 1, false, 160);
  add(2, 1, false, 170);
  add(3, 1, false, 180);
  add(4, 3, false, 200);
  add(4, 3, false, 210);
  add(5, 7, false, 260);
  add(5, 7, false, 300, true);
  add(5, 7, true, 310, true);
  add(5, 2, true, 310, true, true);
  add(5, 2, true, 310, true, true);
  auto views = summarize_views(f);
  ASSERT_EQ(views.size(), 3u);
  EXPECT_EQ(views[0].view, 0u);
  EXPECT_EQ(views[0].frames, 3u);
  EXPECT_TRUE(views[0].converged);
  EXPECT_EQ(views[0].frames_to_converge, 2u);
  EXPECT_DOUBLE_EQ(views[0].ms_to_converge, 30.0);
  EXPECT_EQ(views[0].bytes_read_to_converge, 150u);
  EXPECT_EQ(views[1].view, 4u);
  EXPECT_EQ(views[1].first_frame, 6u);
  EXPECT_FALSE(views[1].converged);
  EXPECT_EQ(views[2].view, 5u);
  EXPECT_EQ(views[2].first_frame, 8u);
  EXPECT_EQ(views[2].frames, 3u);
  EXPECT_EQ(views[2].settle_frames, 2u);
  EXPECT_TRUE(views[2].converged);
  EXPECT_EQ(views[2].frames_to_converge, 3u);
  EXPECT_DOUBLE_EQ(views[2].ms_to_converge, 21.0);
  EXPECT_EQ(views[2].bytes_read_to_converge, 310u - 210u);
  EXPECT_EQ(views[2].wanted_bytes_at_convergence, 300u);
  EXPECT_EQ(summarize_views(f, true).size(), 6u);
  EXPECT_TRUE(summarize_views({}).empty());
}

TEST(StressReport, BeladyBoundsLruAndFifoOnUnitSizes) {
  // With unit sizes Belady's MIN is optimal among demand-paging policies: never fewer hits than
  // LRU or FIFO on the same trace, and bypass never fewer than demand.
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<streaming::TraceRequest> trace;
    const uint32_t nodes = 5 + rng() % 40;
    for (int i = 0; i < 2000; ++i) {
      // Mix of locality (recent nodes) and jumps.
      uint32_t n = (rng() % 4 == 0) ? rng() % nodes : (trace.empty() ? 0 : trace[trace.size() - 1 - rng() % std::min<size_t>(trace.size(), 5)].node);
      trace.push_back({n, 1000});
    }
    const uint64_t budget = 1000 * (1 + rng() % nodes);
    SimBounds b = simulate_bounds(trace, budget);
    EXPECT_EQ(b.budget_bytes, budget);
    EXPECT_EQ(b.belady.requests, trace.size());
    EXPECT_GE(b.belady.hits, b.lru.hits) << "trial " << trial;
    EXPECT_GE(b.belady.hits, b.fifo.hits) << "trial " << trial;
    EXPECT_GE(b.belady_bypass.hits, b.belady.hits) << "trial " << trial;
    for (const auto* r : {&b.belady, &b.belady_bypass, &b.lru, &b.fifo}) {
      EXPECT_GE(r->hit_rate(), 0.0);
      EXPECT_LE(r->hit_rate(), 1.0);
    }
  }
}

TEST(StressReport, CsvFlattensScalarsAndQuotesStrings) {
  nlohmann::ordered_json j;
  j["store"] = "a,b \"c\".mds";
  j["hits"] = 3;
  j["rate"] = 0.25;
  j["none"] = nullptr;
  j["evictions"] = {{"O", 1}, {"M", 2}};
  j["views"] = nlohmann::ordered_json::array({1, 2});
  const std::string csv = csv_summary(j);
  EXPECT_EQ(csv, "store,hits,rate,none,evictions_O,evictions_M\n\"a,b \"\"c\"\".mds\",3,0.25,,1,2\n");
}
