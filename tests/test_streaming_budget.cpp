// Tests of streaming/budget.h: byte-size parsing and the single device payload accountant.
#include <gtest/gtest.h>

#include <random>

#include "streaming/budget.h"

using namespace mds;
using namespace mds::streaming;

TEST(StreamingBudget, ParsesUnits) {
  EXPECT_EQ(*parse_byte_size("512MiB"), 512ull << 20);
  EXPECT_EQ(*parse_byte_size("2GiB"), 2ull << 30);
  EXPECT_EQ(*parse_byte_size("1.5G"), 3ull << 29);
  EXPECT_EQ(*parse_byte_size("1048576"), 1048576ull);
  EXPECT_EQ(*parse_byte_size(" 64 k "), 65536ull);
  EXPECT_EQ(*parse_byte_size("100MB"), 100000000ull);
  EXPECT_EQ(*parse_byte_size("3B"), 3ull);
  EXPECT_EQ(*parse_byte_size("1tib"), 1ull << 40);
}

TEST(StreamingBudget, RejectsBadSizes) {
  for (const char* bad : {"", "MiB", "12XB", "1.5", "-3G", "1e3G", "1..5G", "99999999999999999999999T"}) {
    auto r = parse_byte_size(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, Errc::invalid_argument) << bad;
    EXPECT_NE(r.error().message.find(std::string("'") + bad + "'"), std::string::npos) << r.error().message;
  }
}

TEST(StreamingBudget, AccountingKeepsPeakWithinPool) {
  const uint64_t pool = 1000;
  DeviceBudget b(pool);
  std::mt19937_64 rng(7);
  std::vector<uint64_t> held;
  uint64_t expect_used = 0, expect_peak = 0;
  for (int step = 0; step < 5000; ++step) {
    if (!held.empty() && (rng() % 3 == 0)) {
      size_t k = rng() % held.size();
      ASSERT_TRUE(b.release(held[k]).ok());
      expect_used -= held[k];
      held.erase(held.begin() + std::ptrdiff_t(k));
    } else {
      uint64_t want = 1 + rng() % 300;
      Status s = b.reserve(want);
      if (expect_used + want <= pool) {
        ASSERT_TRUE(s.ok());
        held.push_back(want);
        expect_used += want;
        expect_peak = std::max(expect_peak, expect_used);
      } else {
        ASSERT_FALSE(s.ok());
        EXPECT_EQ(s.error().code, Errc::budget);
      }
    }
    ASSERT_EQ(b.used_bytes(), expect_used);
    ASSERT_LE(b.peak_bytes(), b.pool_bytes());
  }
  EXPECT_EQ(b.peak_bytes(), expect_peak);
  EXPECT_GT(expect_peak, pool / 2);
}

TEST(StreamingBudget, OverReservationIsBudgetError) {
  DeviceBudget b(4096);
  Status s = b.reserve(4097, "node 12");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, Errc::budget);
  EXPECT_NE(s.error().message.find("node 12"), std::string::npos);
  EXPECT_NE(s.error().message.find("4097"), std::string::npos);
  EXPECT_EQ(b.used_bytes(), 0u);
  EXPECT_FALSE(b.check_fits_pool(5000, "x").ok());
  EXPECT_TRUE(b.check_fits_pool(4096, "x").ok());
  EXPECT_TRUE(b.reserve(4096).ok());
  EXPECT_EQ(b.peak_bytes(), 4096u);
  Status over = b.release(5000);
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().code, Errc::internal);
}
