// Per-node property histograms (store/property_histogram.h, format.h kFlagPropertyHistogram):
// the bin rule against a brute-force count, the checks a reader applies to a hostile record, what
// a threshold's keep table makes of a node (none and all exact, the share from the bins), and in
// a store: the writer's records equal the decoded payloads' histograms, a lying record is refused
// when opened (counts) or by verify_property_histogram (`info --verify`), a flipped byte by the
// section's checksum.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

#include "store/format.h"
#include "store/hash.h"
#include "store/property_histogram.h"
#include "store/store_reader.h"
#include "store/store_writer.h"
#include "store/threshold.h"

namespace mds {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// Every value of [q_min, q_max] falls in the bin whose first value is the largest first <= it,
// and every bin's values are consecutive: the bins tile the range.
TEST(PropertyHistogram, BinsTileTheRange) {
  for (const auto& [lo, hi] : std::vector<std::pair<uint16_t, uint16_t>>{
           {0, 0}, {7, 7}, {0, 29}, {0, 30}, {5, 64}, {100, 130}, {0, 65535}, {65535, 65535}, {1234, 50000}}) {
    store::PropertyHistogram h{};
    h.q_min = lo;
    h.q_max = hi;
    EXPECT_EQ(store::property_bin_first(h, 0), lo);
    EXPECT_EQ(store::property_bin_first(h, store::kPropertyBins), uint32_t(hi) + 1);
    for (uint32_t q = lo; q <= hi; ++q) {
      const uint32_t b = store::property_bin(h, q);
      ASSERT_LT(b, store::kPropertyBins);
      ASSERT_LE(store::property_bin_first(h, b), q) << lo << " " << hi << " " << q;
      ASSERT_GT(store::property_bin_first(h, b + 1), q) << lo << " " << hi << " " << q;
    }
  }
}

TEST(PropertyHistogram, CountsAndChecks) {
  std::mt19937 rng(7);
  std::vector<uint16_t> q;
  for (int i = 0; i < 5000; ++i) q.push_back(uint16_t(20000 + rng() % 9000));
  const store::PropertyHistogram h = store::make_property_histogram(q);
  EXPECT_EQ(h.q_min, *std::min_element(q.begin(), q.end()));
  EXPECT_EQ(h.q_max, *std::max_element(q.begin(), q.end()));
  uint32_t brute[store::kPropertyBins] = {};
  for (uint16_t v : q) ++brute[uint64_t(v - h.q_min) * store::kPropertyBins / (h.q_max - h.q_min + 1)];
  for (uint32_t b = 0; b < store::kPropertyBins; ++b) EXPECT_EQ(h.counts[b], brute[b]) << b;
  EXPECT_TRUE(store::check_property_histogram(h, 5000).ok());
  EXPECT_THAT(store::check_property_histogram(h, 5001).error().message, HasSubstr("counts sum to 5000, the node has 5001"));
  store::PropertyHistogram bad = h;
  std::swap(bad.q_min, bad.q_max);
  EXPECT_THAT(store::check_property_histogram(bad, 5000).error().message, HasSubstr("q_min"));
  // Three values, 30 bins: a bin that holds no value must count nothing.
  const std::vector<uint16_t> few = {10, 11, 12, 12};
  store::PropertyHistogram f = store::make_property_histogram(few);
  EXPECT_TRUE(store::check_property_histogram(f, 4).ok());
  uint32_t empty_bin = 0;
  while (store::property_bin_first(f, empty_bin) < store::property_bin_first(f, empty_bin + 1)) ++empty_bin;
  const uint32_t full_bin = store::property_bin(f, 12);
  --f.counts[full_bin];
  ++f.counts[empty_bin];
  EXPECT_THAT(store::check_property_histogram(f, 4).error().message, HasSubstr("holds no value"));
  // The node's largest value must lie in a bin that counts something.
  f = store::make_property_histogram(few);
  f.counts[store::property_bin(f, 12)] -= 2;
  f.counts[store::property_bin(f, 11)] += 2;
  EXPECT_THAT(store::check_property_histogram(f, 4).error().message, HasSubstr("q_max 12"));
}

// none and all are exact; the share of a cut node is the bins' kept share, exact where the
// threshold falls on a bin edge and particles are uniform.
TEST(PropertyHistogram, CoverOfAThreshold) {
  std::vector<uint16_t> q;
  for (uint32_t v = 3000; v < 6000; ++v) q.push_back(uint16_t(v));  // 100 values per bin
  const store::PropertyHistogram h = store::make_property_histogram(q);
  auto cover = [&](double lo, double hi, bool invert) {
    // property_min 0, property_max 65535: the value is q itself.
    const auto table = store::threshold_table({lo, hi, invert}, 0.0f, 65535.0f);
    return store::property_cover(h, store::kept_prefix_sums(table));
  };
  constexpr double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(cover(6000, inf, false).cover, store::SliceCover::none);
  EXPECT_EQ(cover(-inf, 2999, false).cover, store::SliceCover::none);
  EXPECT_EQ(cover(3000, 5999, false).cover, store::SliceCover::all);
  EXPECT_EQ(cover(3000, 5999, true).cover, store::SliceCover::none);
  EXPECT_EQ(cover(0, 10, true).cover, store::SliceCover::all);
  const store::PropertyCover third = cover(5000, inf, false);
  EXPECT_EQ(third.cover, store::SliceCover::some);
  EXPECT_NEAR(third.share, 1.0 / 3.0, 1e-12);
  const store::PropertyCover half_bin = cover(-inf, 3049, false);  // half of bin 0
  EXPECT_NEAR(half_bin.share, 50.0 / 3000.0, 1e-12);
  EXPECT_NEAR(cover(5000, inf, true).share, 2.0 / 3.0, 1e-12);
  // A node with values on both sides of a range the threshold keeps but none in it: `some` (its
  // range overlaps the kept one); the reader thread that reads it finds it empty.
  const std::vector<uint16_t> two = {100, 200};
  const store::PropertyHistogram g = store::make_property_histogram(two);
  const auto table = store::threshold_table({120, 180, false}, 0.0f, 65535.0f);
  EXPECT_EQ(store::property_cover(g, store::kept_prefix_sums(table)).cover, store::SliceCover::some);  // range overlaps
}

class PropertyHistogramStore : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mds_property_histogram_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    auto w = store::StoreWriter::create(dir_ / "s.mds");
    ASSERT_TRUE(w.ok()) << w.error().message;
    std::mt19937 rng(3);
    for (int node = 0; node < 3; ++node) {
      const size_t n = 40 + 30 * size_t(node);
      std::vector<uint16_t> qpos(3 * n), prop(n);
      std::vector<uint8_t> types(n, 0), sizes;
      for (auto& v : qpos) v = uint16_t(rng());
      for (auto& v : prop) v = uint16_t(node * 20000 + rng() % 15000);
      for (size_t done = 0; done < n; done += 10) sizes.push_back(uint8_t(std::min<size_t>(10, n - done)));
      store::NodeInput in{};
      in.qpos = qpos;
      in.type_index = types;
      in.property_q = prop;
      in.meshlet_size = sizes;
      for (int a = 0; a < 3; ++a) in.center_min[a] = node, in.center_max[a] = node + 1.0;
      in.max_radius = 0.1f;
      auto e = store::encode_node(in);
      ASSERT_TRUE(e.ok()) << e.error().message;
      ASSERT_TRUE((*w)->append(std::move(*e)).ok());
    }
    store::StoreSummary sum;
    sum.flags = store::kFlagProperty;
    sum.node_size_max = 100;
    sum.meshlet_size_max = 10;
    sum.bounds_max[0] = sum.bounds_max[1] = sum.bounds_max[2] = 3.0;
    sum.property_name = "c_pe";
    sum.property_min = -1.0f;
    sum.property_max = 1.0f;
    store::TypeEntry t{};
    t.radius = 0.1f;
    sum.types.push_back(t);
    ASSERT_TRUE((*w)->finish(sum).ok());
    std::ifstream f(dir_ / "s.mds", std::ios::binary);
    good_.assign(std::istreambuf_iterator<char>(f), {});
  }
  void TearDown() override { fs::remove_all(dir_); }
  // The store with `edit` applied to its bytes (the header resealed when `reseal_section`: the
  // section's hash made to match, so that only the content check can refuse it).
  Result<std::unique_ptr<store::StoreReader>> open_edited(size_t at, uint16_t value, bool reseal_section) {
    std::vector<uint8_t> b = good_;
    std::memcpy(b.data() + at, &value, 2);
    if (reseal_section) {
      store::FileHeader h;
      std::memcpy(&h, b.data(), sizeof h);
      h.property_histograms.hash =
          store::hash_bytes({b.data() + h.property_histograms.offset, size_t(h.property_histograms.bytes)});
      h.header_hash = 0;
      h.header_hash = store::hash_bytes({reinterpret_cast<const uint8_t*>(&h), sizeof h});
      std::memcpy(b.data(), &h, sizeof h);
    }
    const fs::path p = dir_ / "edited.mds";
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
    return store::StoreReader::open(p);
  }
  fs::path dir_;
  std::vector<uint8_t> good_;
};

TEST_F(PropertyHistogramStore, WrittenRecordsAreThoseOfThePayloads) {
  auto r = store::StoreReader::open(dir_ / "s.mds");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const store::FileHeader& h = (*r)->header();
  EXPECT_EQ(h.flags & store::kFlagPropertyHistogram, uint32_t(store::kFlagPropertyHistogram));
  EXPECT_EQ(h.property_histograms.offset + h.property_histograms.bytes, good_.size());  // last in the file
  ASSERT_EQ((*r)->property_histograms().size(), 3u);
  store::NodeData d;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < 3; ++i) {
    ASSERT_TRUE((*r)->read_node(i, d, scratch).ok());
    const store::PropertyHistogram want = store::make_property_histogram(d.property_q);
    EXPECT_EQ(std::memcmp(&want, &(*r)->property_histograms()[i], sizeof want), 0) << i;
    EXPECT_TRUE((*r)->verify_property_histogram(i, d).ok());
  }
}

TEST_F(PropertyHistogramStore, LyingRecordsAreRefused) {
  store::FileHeader h;
  std::memcpy(&h, good_.data(), sizeof h);
  const size_t node1 = size_t(h.property_histograms.offset) + sizeof(store::PropertyHistogram);
  store::PropertyHistogram rec;
  std::memcpy(&rec, good_.data() + node1, sizeof rec);
  // A flipped byte: the section's checksum.
  auto a = open_edited(node1 + 4, uint16_t(rec.counts[0] ^ 1), false);
  ASSERT_FALSE(a.ok());
  EXPECT_THAT(a.error().message, HasSubstr("property histogram section at byte " + std::to_string(h.property_histograms.offset) +
                                           ": checksum mismatch"));
  // Counts that do not sum to the node's particles, resealed: named with the node and its byte.
  auto b = open_edited(node1 + 4, uint16_t(rec.counts[0] + 1), true);
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().code, Errc::format);
  EXPECT_THAT(b.error().message, HasSubstr("node 1 property histogram at byte " + std::to_string(node1) +
                                           ": counts sum to 71, the node has 70"));
  // A consistent record that is not the node's (its range moved up by one): only decoding the
  // payload finds it (info --verify).
  auto c = open_edited(node1, uint16_t(rec.q_min + 1), true);
  if (c.ok()) {  // the moved range may also break a bin rule, then open refuses it
    store::NodeData d;
    std::vector<uint8_t> scratch;
    ASSERT_TRUE((*c)->read_node(1, d, scratch).ok());
    const Status st = (*c)->verify_property_histogram(1, d);
    ASSERT_FALSE(st.ok());
    EXPECT_THAT(st.error().message, HasSubstr("node 1 property histogram at byte " + std::to_string(node1)));
  } else {
    EXPECT_THAT(c.error().message, HasSubstr("node 1 property histogram"));
  }
  // Truncated: the section runs past the end.
  const fs::path p = dir_ / "short.mds";
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(good_.data()), std::streamsize(good_.size() - 10));
  auto t = store::StoreReader::open(p);
  ASSERT_FALSE(t.ok());
  EXPECT_THAT(t.error().message, HasSubstr("property_histograms.bytes"));
}

}  // namespace
}  // namespace mds
