// Unit tests of the converter's pieces: Morton keys, radix sort, octree partition and node
// building, both meshlet builders and their quality measure, quantization, density grid, spill
// files and out-of-core binning, option parsing.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "convert/binning.h"
#include "convert/converter.h"
#include "core/byte_size.h"
#include "convert/density.h"
#include "convert/meshlet_builder.h"
#include "convert/meshlet_quality.h"
#include "convert/morton.h"
#include "convert/node_builder.h"
#include "convert/quantize.h"
#include "convert/radix_sort.h"
#include "convert/spill.h"
#include "convert/xyz_sort.h"
#include "scoped_temp_dir.h"

using namespace mds;
using namespace mds::convert;

namespace {

struct KeyedRecord {
  uint64_t key;
  SpillRecord r;
};

std::vector<uint64_t> keys_of(const std::vector<KeyedRecord>& recs) {
  std::vector<uint64_t> k;
  for (const auto& r : recs) k.push_back(r.key);
  return k;
}

std::vector<KeyedRecord> sorted_records(std::vector<SpillRecord> in, double lo[3], double hi[3]) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = 1e300;
    hi[a] = -1e300;
  }
  for (const auto& r : in) {
    const double p[3] = {r.x, r.y, r.z};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  MortonGrid g(lo, hi);
  std::vector<KeyedRecord> out;
  for (const auto& r : in) out.push_back({g.key(r.x, r.y, r.z), r});
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
  return out;
}

std::vector<SpillRecord> uniform(size_t n, double ext, uint32_t seed, double offset = 0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, ext);
  std::vector<SpillRecord> v(n);
  for (auto& r : v) r = {offset + u(rng), offset + u(rng), offset + u(rng), int32_t(rng() % 3) + 1, 0.5f};
  return v;
}

struct Box {
  double lo[3] = {1e300, 1e300, 1e300};
  double hi[3] = {-1e300, -1e300, -1e300};
  void add(double x, double y, double z) {
    const double p[3] = {x, y, z};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  double volume() const { return (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]); }
  double max_extent() const { return std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}); }
};

struct TmpDir : mds::test::ScopedTempDir {
  TmpDir() : ScopedTempDir("mds_convert_units_") {}
};

}  // namespace

// ---------------------------------------------------------------- Morton

TEST(Morton, InterleavesBits) {
  EXPECT_EQ(morton_encode(1, 0, 0), 1u);
  EXPECT_EQ(morton_encode(0, 1, 0), 2u);
  EXPECT_EQ(morton_encode(0, 0, 1), 4u);
  EXPECT_EQ(morton_encode(2, 0, 0), 8u);
  EXPECT_EQ(morton_encode(kMortonAxisMax, kMortonAxisMax, kMortonAxisMax), (1ull << 63) - 1);
}

TEST(Morton, RoundTripsRandomCoordinates) {
  std::mt19937 rng(1);
  for (int i = 0; i < 10000; ++i) {
    const uint32_t x = rng() & kMortonAxisMax, y = rng() & kMortonAxisMax, z = rng() & kMortonAxisMax;
    uint32_t a, b, c;
    morton_decode(morton_encode(x, y, z), a, b, c);
    ASSERT_EQ(a, x);
    ASSERT_EQ(b, y);
    ASSERT_EQ(c, z);
  }
}

TEST(Morton, CubeOfSide2kMapsOntoKeyRange8k) {
  // A Z-order property the binning relies on: the octree cell [0,2^k)^3 is exactly the key range [0, 8^k).
  const uint32_t side = 8;
  std::set<uint64_t> keys;
  for (uint32_t x = 0; x < side; ++x)
    for (uint32_t y = 0; y < side; ++y)
      for (uint32_t z = 0; z < side; ++z) keys.insert(morton_encode(x, y, z));
  EXPECT_EQ(keys.size(), side * side * side);
  EXPECT_EQ(*keys.begin(), 0u);
  EXPECT_EQ(*keys.rbegin(), uint64_t(side * side * side - 1));
  // and child bits / prefixes agree with the cell coordinates
  const uint64_t k = morton_encode(5u << 18, 3u << 18, 6u << 18);
  EXPECT_EQ(morton_child(k, 0), ((5u >> 2) & 1) | (((3u >> 2) & 1) << 1) | (((6u >> 2) & 1) << 2));
  EXPECT_EQ(morton_prefix(k, 9), morton_encode(5, 3, 6));
}

TEST(Morton, GridMapsBoundsAndClamps) {
  const double lo[3] = {-1, 0, 10}, hi[3] = {1, 0, 20};  // y degenerate, z the longest axis
  MortonGrid g(lo, hi);
  EXPECT_EQ(g.cell(2, 10), 0u);
  EXPECT_EQ(g.cell(2, 20), kMortonAxisMax);
  EXPECT_EQ(g.cell(2, 15), 1u << 20);
  // cubic cells: x (extent 2 of 10) uses a fifth of the range
  EXPECT_EQ(g.cell(0, -1), 0u);
  EXPECT_EQ(g.cell(0, 1), uint32_t(2.0 / 10.0 * double(1u << kMortonBitsPerAxis)));
  EXPECT_EQ(g.cell(0, -5), 0u);
  EXPECT_EQ(g.cell(0, 50), kMortonAxisMax);
  EXPECT_EQ(g.cell(1, 0), 0u);
  EXPECT_LT(g.key(-0.9, 0, 10.1), g.key(0.9, 0, 19.9));
}

// ---------------------------------------------------------------- nodes

static void check_partition(const std::vector<NodeRange>& nodes, size_t n, uint32_t node_size) {
  ASSERT_FALSE(nodes.empty());
  EXPECT_EQ(nodes.front().begin, 0u);
  EXPECT_EQ(nodes.back().end, n);
  for (size_t i = 0; i < nodes.size(); ++i) {
    EXPECT_GT(nodes[i].size(), 0u);
    EXPECT_LE(nodes[i].size(), node_size);
    if (i > 0) {
      EXPECT_EQ(nodes[i].begin, nodes[i - 1].end);
    }
  }
}

TEST(NodeBuilder, UniformDataGivesCompactNodesWithinSize) {
  double lo[3], hi[3];
  auto recs = sorted_records(uniform(200000, 100.0, 7), lo, hi);
  const uint32_t node_size = 10000;
  auto nodes = build_nodes(keys_of(recs), 0, node_size);
  check_partition(nodes, recs.size(), node_size);
  // Not tiny: merging keeps the mean well above a quarter of the limit.
  EXPECT_GT(double(recs.size()) / double(nodes.size()), node_size / 4.0);
  // Compact: node boxes tile the domain (sum ~ 1 box), where a non-spatial grouping of the
  // same sizes would give about nodes.size() boxes.
  double sum = 0;
  for (const auto& nr : nodes) {
    Box b;
    for (size_t i = nr.begin; i < nr.end; ++i) b.add(recs[i].r.x, recs[i].r.y, recs[i].r.z);
    sum += b.volume();
  }
  const double global = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
  EXPECT_LT(sum, 1.5 * global);
  EXPECT_GT(nodes.size(), 10u);
}

TEST(NodeBuilder, ClusteredDataNodesCoverLittleOfTheBox) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0, 1);
  std::vector<SpillRecord> v;
  for (int i = 0; i < 60000; ++i) {
    const double c = (i % 2) ? 0.0 : 1000.0;
    v.push_back({c + g(rng), c + g(rng), c + g(rng), 1, 0.5f});
  }
  double lo[3], hi[3];
  auto recs = sorted_records(v, lo, hi);
  auto nodes = build_nodes(keys_of(recs), 0, 5000);
  check_partition(nodes, recs.size(), 5000);
  double sum = 0;
  for (const auto& nr : nodes) {
    Box b;
    for (size_t i = nr.begin; i < nr.end; ++i) b.add(recs[i].r.x, recs[i].r.y, recs[i].r.z);
    sum += b.volume();
  }
  const double global = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
  EXPECT_LT(sum, 1e-3 * global);
}

TEST(NodeBuilder, SmallInputIsOneNodeAndDuplicatesAreChunked) {
  double lo[3], hi[3];
  auto small = sorted_records(uniform(500, 1.0, 9), lo, hi);
  auto n1 = build_nodes(keys_of(small), 0, 10000);
  ASSERT_EQ(n1.size(), 1u);
  EXPECT_EQ(n1[0].size(), 500u);
  // 25000 identical points cannot be split spatially: chunks of node_size.
  std::vector<SpillRecord> same(25000, SpillRecord{1, 2, 3, 1, 0.5f});
  same.push_back({0, 0, 0, 1, 0.5f});
  auto recs = sorted_records(same, lo, hi);
  auto n2 = build_nodes(keys_of(recs), 0, 10000);
  check_partition(n2, recs.size(), 10000);
}

TEST(NodeBuilder, NodesStayInsideTheStartCell) {
  // Build a depth-1 cell (one bin of the out-of-core path): every node's keys share the bin prefix
  // and each node lies inside one octree cell of some depth >= 1.
  double lo[3], hi[3];
  auto all = sorted_records(uniform(80000, 10.0, 11), lo, hi);
  std::vector<KeyedRecord> bin;
  for (const auto& r : all)
    if (morton_prefix(r.key, 3) == 5) bin.push_back(r);
  ASSERT_GT(bin.size(), 5000u);
  auto nodes = build_nodes(keys_of(bin), 1, 1000);
  check_partition(nodes, bin.size(), 1000);
  for (const auto& nr : nodes) {
    const uint64_t a = bin[nr.begin].key, b = bin[nr.end - 1].key;
    EXPECT_EQ(morton_prefix(a, 3), morton_prefix(b, 3));
  }
}

// ---------------------------------------------------------------- radix sort

TEST(RadixSort, MatchesStableSortOnUniformClusteredAndEqualKeys) {
  std::mt19937_64 rng(21);
  auto check = [](std::vector<uint64_t> keys, unsigned threads) {
    std::vector<uint32_t> idx(keys.size());
    std::iota(idx.begin(), idx.end(), 0u);
    std::vector<std::pair<uint64_t, uint32_t>> ref;
    for (size_t i = 0; i < keys.size(); ++i) ref.push_back({keys[i], uint32_t(i)});
    std::stable_sort(ref.begin(), ref.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    std::vector<uint64_t> kt(keys.size());
    std::vector<uint32_t> it(keys.size());
    radix_sort_pairs(keys, idx, kt, it, threads);
    ASSERT_EQ(keys.size(), ref.size());
    for (size_t i = 0; i < ref.size(); ++i) {
      ASSERT_EQ(keys[i], ref[i].first) << "at " << i << ", " << threads << " threads";
      ASSERT_EQ(idx[i], ref[i].second) << "at " << i << " (stability), " << threads << " threads";
    }
  };
  std::vector<uint64_t> uniform_keys(300000), clustered(400000), narrow(200000), equal(100000, 12345);
  for (auto& k : uniform_keys) k = rng() >> 1;  // 63-bit Morton keys
  // 95% in one tiny cell (forces MSD recursion inside a bucket), many duplicates, plus outliers.
  for (size_t i = 0; i < clustered.size(); ++i)
    clustered[i] = (i % 20 == 0) ? (rng() >> 1) : ((uint64_t(5) << 59) | (rng() % 70000) * 977);
  for (auto& k : narrow) k = (uint64_t(1) << 62) + (rng() % 1000);  // shared prefix: most digits skipped
  for (unsigned threads : {1u, 2u, 3u}) {
    check(uniform_keys, threads);
    check(clustered, threads);
    check(narrow, threads);
    check(equal, threads);
  }
  check({}, 2);
  check({7}, 2);
  check({9, 3, 3, 1, 9, 0}, 2);
}

// The raw-input sort moves the positions with the keys; it must equal a stable sort by key
// (ties in input order), for uniform, clustered (one MSD bucket holds most) and duplicated data.
TEST(XyzSort, MatchesStableSortByKeyAndMovesPositions) {
  std::mt19937_64 rng(11);
  auto check = [&](const std::vector<float>& xyz, unsigned threads) {
    const size_t n = xyz.size() / 3;
    double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
    for (size_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], double(xyz[3 * i + a])), hi[a] = std::max(hi[a], double(xyz[3 * i + a]));
    const MortonGrid grid(lo, hi);
    std::vector<std::pair<uint64_t, size_t>> ref(n);
    for (size_t i = 0; i < n; ++i) ref[i] = {grid.key(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]), i};
    std::stable_sort(ref.begin(), ref.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    std::vector<float> sorted(3 * n);
    sort_xyz_by_key(xyz.data(), n, grid, threads, sorted.data());
    std::vector<uint64_t> keys(n);
    morton_keys_of_xyz(sorted.data(), n, grid, keys.data());
    const XyzMortonKeys on_access{sorted.data(), n, &grid};
    for (size_t i = 0; i < n; ++i) {
      ASSERT_EQ(keys[i], ref[i].first) << "at " << i << ", " << threads << " threads";
      ASSERT_EQ(on_access[i], ref[i].first) << "at " << i;
      for (int a = 0; a < 3; ++a)
        ASSERT_EQ(sorted[3 * i + a], xyz[3 * ref[i].second + a]) << "particle " << i << " axis " << a << " (stability)";
    }
    // The partition over keys computed on access equals the one over the key array.
    for (uint32_t cap : {1000u, 64u}) {
      const auto a = build_nodes(std::span<const uint64_t>(keys), 0, cap), b = build_nodes(on_access, 0, cap);
      ASSERT_EQ(a.size(), b.size()) << cap;
      for (size_t k = 0; k < a.size(); ++k) ASSERT_TRUE(a[k].begin == b[k].begin && a[k].end == b[k].end) << k;
    }
  };
  std::uniform_real_distribution<float> u(-50.0f, 150.0f);
  std::vector<float> uniform(3 * 200000), clustered(3 * 150000), duplicated(3 * 100000);
  for (auto& v : uniform) v = u(rng);
  for (size_t i = 0; i < clustered.size(); ++i)  // 95 % in a tiny cube, a few far away
    clustered[i] = (i / 3) % 20 == 0 ? u(rng) : 7.0f + 1e-3f * float(rng() % 1000);
  for (size_t i = 0; i < duplicated.size(); ++i) duplicated[i] = float(rng() % 4);  // 64 distinct positions
  for (unsigned threads : {1u, 2u, 3u}) {
    check(uniform, threads);
    check(clustered, threads);
    check(duplicated, threads);
  }
  check({1.0f, 2.0f, 3.0f}, 2);
  check({5, 5, 5, 1, 1, 1, 5, 5, 5, 0, 9, 0}, 2);
}

// ---------------------------------------------------------------- meshlets

struct MeshletStats {
  double mean_size = 0;
  double mean_extent = 0;
  size_t max_size = 0;
  MeshletQuality quality;
};

// Keys and interleaved positions of sorted records.
struct NodeData {
  std::vector<uint64_t> keys;
  std::vector<double> xyz;
};
static NodeData node_data(const std::vector<KeyedRecord>& recs) {
  NodeData d;
  for (const auto& r : recs) {
    d.keys.push_back(r.key);
    d.xyz.insert(d.xyz.end(), {r.r.x, r.r.y, r.r.z});
  }
  return d;
}
static NodeData node_data(const std::vector<SpillRecord>& v) {
  double lo[3], hi[3];
  return node_data(sorted_records(v, lo, hi));
}

// Builds meshlets and checks they partition the node: every index exactly once, sizes 1..msize.
static MeshletStats check_meshlets(MeshletBuilderKind kind, const NodeData& d, uint32_t msize) {
  auto mb = std::move(make_meshlet_builder(kind).value());
  std::vector<uint32_t> order;
  std::vector<uint8_t> sizes;
  const auto& xyz = d.xyz;
  const size_t n = xyz.size() / 3;
  auto st0 = mb->build(d.keys, xyz, msize, order, sizes);
  EXPECT_TRUE(st0.ok()) << (st0.ok() ? "" : st0.error().message);
  EXPECT_EQ(order.size(), n);
  std::vector<uint8_t> seen(n, 0);
  for (auto i : order) {
    EXPECT_LT(i, n);
    if (i < n) {
      EXPECT_EQ(seen[i], 0) << "particle in two meshlets";
      seen[i] = 1;
    }
  }
  EXPECT_EQ(std::accumulate(sizes.begin(), sizes.end(), size_t(0)), n);
  MeshletStats st;
  size_t at = 0;
  for (auto s : sizes) {
    EXPECT_GE(s, 1);
    EXPECT_LE(s, msize);
    st.max_size = std::max<size_t>(st.max_size, s);
    Box b;
    for (size_t k = at; k < at + s; ++k) b.add(xyz[3 * order[k]], xyz[3 * order[k] + 1], xyz[3 * order[k] + 2]);
    st.mean_extent += b.max_extent();
    at += s;
  }
  st.mean_size = double(n) / double(sizes.size());
  st.mean_extent /= double(sizes.size());
  add_meshlet_quality(xyz, order, sizes, st.quality);
  return st;
}

constexpr MeshletBuilderKind kBothBuilders[] = {MeshletBuilderKind::pcl, MeshletBuilderKind::octree};

TEST(MeshletBuilder, PartitionsUniformNodeIntoCompactMeshletsOf16) {
  const NodeData d = node_data(uniform(10000, 1.0, 5));
  auto pcl = check_meshlets(MeshletBuilderKind::pcl, d, 16);
  EXPECT_GT(pcl.mean_size, 14.0);
  EXPECT_EQ(pcl.max_size, 16u);
  // 16 of 10000 uniform points in a unit cube: a ball of radius ~0.07; random groups span ~0.9.
  EXPECT_LT(pcl.mean_extent, 0.25);
  auto oct = check_meshlets(MeshletBuilderKind::octree, d, 16);
  EXPECT_EQ(oct.max_size, 16u);
  EXPECT_GT(oct.mean_size, 8.0);  // binary-halves merging keeps leaves above half the capacity on average
  EXPECT_LT(oct.mean_extent, 0.25);
}

TEST(MeshletBuilder, BothWorkFarFromOriginAndOnDegenerateData) {
  for (auto kind : kBothBuilders) {
    SCOPED_TRACE(meshlet_builder_name(kind));
    // 1e6 offset with 1e-3 spacing: float-relative coordinates keep neighbourhoods meaningful.
    auto st = check_meshlets(kind, node_data(uniform(4000, 0.05, 6, 1.0e6)), 16);
    EXPECT_GT(st.mean_size, kind == MeshletBuilderKind::pcl ? 14.0 : 8.0);
    EXPECT_LT(st.mean_extent, 0.05 * 0.4);
    // all points identical: keys equal, chunks of the capacity
    auto st2 = check_meshlets(kind, node_data(std::vector<SpillRecord>(100, SpillRecord{4, 4, 4, 1, 0.5f})), 16);
    EXPECT_EQ(st2.max_size, 16u);
    // flat (2D) data, other meshlet sizes
    std::vector<SpillRecord> flat;
    std::mt19937 rng(2);
    for (int i = 0; i < 3000; ++i) flat.push_back({double(rng() % 1000), double(rng() % 1000), 0.0, 1, 0.5f});
    const NodeData fd = node_data(flat);
    check_meshlets(kind, fd, 1);
    check_meshlets(kind, fd, 255);
    check_meshlets(kind, fd, 7);
    check_meshlets(kind, node_data(std::vector<SpillRecord>{{1, 2, 3, 1, 0.5f}}), 16);
  }
}

// Random nodes of many sizes and shapes (clusters, duplicates, a line), every meshlet size
// class: both builders partition them (check_meshlets), and the PCL builder's widening of the
// kd-tree query (late seeds whose neighbourhood is used up, nodes of two or three leaves) still
// fills its meshlets.
TEST(MeshletBuilder, PartitionsRandomNodesOfManySizes) {
  std::mt19937_64 rng(31);
  const uint32_t meshlet_sizes[] = {2, 5, 16, 31, 64};
  for (int trial = 0; trial < 40; ++trial) {
    const size_t n = 3 + rng() % 3000;
    const uint32_t msize = meshlet_sizes[trial % 5];
    std::vector<SpillRecord> recs;
    std::normal_distribution<double> g(0, 1);
    const int clusters = 1 + int(rng() % 4);
    for (size_t i = 0; i < n; ++i) {
      const double c = 20.0 * double(i % size_t(clusters));
      switch (trial % 3) {
        case 0: recs.push_back({c + g(rng), g(rng), g(rng), 1, 0.5f}); break;
        case 1: recs.push_back({double(rng() % 7), double(rng() % 5), 0.0, 1, 0.5f}); break;  // duplicates
        default: recs.push_back({c + 0.01 * double(i), 0.0, 0.0, 1, 0.5f}); break;             // a line
      }
    }
    SCOPED_TRACE(testing::Message() << "trial " << trial << ", n " << n << ", meshlet size " << msize);
    const NodeData d = node_data(recs);
    const auto oct = check_meshlets(MeshletBuilderKind::octree, d, msize);
    const auto pcl = check_meshlets(MeshletBuilderKind::pcl, d, msize);
    // Only a node's last meshlets can stay short: at least as full as the octree leaves.
    EXPECT_GE(pcl.mean_size + 1e-9, oct.mean_size);
  }
}

TEST(MeshletBuilder, RejectsBadArguments) {
  for (auto kind : kBothBuilders) {
    auto mb = std::move(make_meshlet_builder(kind).value());
    std::vector<uint32_t> order;
    std::vector<uint8_t> sizes;
    std::vector<double> xyz = {0, 0, 0, 1, 1, 1};
    std::vector<uint64_t> keys = {0, 7};
    EXPECT_FALSE(mb->build(keys, xyz, 0, order, sizes).ok());
    EXPECT_FALSE(mb->build(keys, xyz, 256, order, sizes).ok());
    EXPECT_FALSE(mb->build(std::vector<uint64_t>{0}, xyz, 16, order, sizes).ok());  // key count != n
  }
  EXPECT_EQ(parse_meshlet_builder("pcl"), MeshletBuilderKind::pcl);
  EXPECT_EQ(parse_meshlet_builder("octree"), MeshletBuilderKind::octree);
  EXPECT_FALSE(parse_meshlet_builder("kdtree").has_value());
}

TEST(MeshletQuality, MeasuresDiagonalOverSpacingOnALattice) {
  // 4x4x4 lattice of spacing 1 in 2x2x2 blocks of 8: node box 3^3 over 64 particles gives a
  // spacing of (27/64)^(1/3) = 0.75; each block's diagonal is sqrt(3).
  std::vector<double> xyz;
  std::vector<uint32_t> order;
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) xyz.insert(xyz.end(), {double(x), double(y), double(z)});
  for (int b = 0; b < 8; ++b)
    for (int k = 0; k < 8; ++k) {
      const int x = 2 * (b & 1) + (k & 1), y = 2 * ((b >> 1) & 1) + ((k >> 1) & 1), z = 2 * (b >> 2) + (k >> 2);
      order.push_back(uint32_t(x + 4 * y + 16 * z));
    }
  std::vector<uint8_t> sizes(8, 8);
  MeshletQuality q;
  add_meshlet_quality(xyz, order, sizes, q);
  EXPECT_NEAR(q.mean_diag_over_spacing(), std::sqrt(3.0) / 0.75, 1e-9);
  EXPECT_DOUBLE_EQ(q.mean_size(), 8.0);
  // Stripes (one x-row of 4 per meshlet, 16 meshlets) on the same lattice: diagonal 3.
  std::vector<uint32_t> rows(64);
  std::iota(rows.begin(), rows.end(), 0u);
  MeshletQuality q2;
  add_meshlet_quality(xyz, rows, std::vector<uint8_t>(16, 4), q2);
  EXPECT_NEAR(q2.mean_diag_over_spacing(), 3.0 / 0.75, 1e-9);
  EXPECT_DOUBLE_EQ(q2.mean_size(), 4.0);
  // A flat node measures over its 2 non-degenerate axes; a point-like node is not measured.
  const double lo[3] = {0, 0, 5}, hi[3] = {4, 9, 5};
  EXPECT_NEAR(mean_spacing(lo, hi, 4), 3.0, 1e-12);
  EXPECT_EQ(mean_spacing(lo, lo, 10), 0.0);
}

// The octree builder trades meshlet fill for speed; its compactness stays within a stated
// factor of the PCL builder's: diag/spacing at most 1.25x PCL's and mean size at least 0.55x.
TEST(MeshletQuality, OctreeBuilderWithinFactorOfPclOnUniformAndClusteredNodes) {
  std::mt19937_64 rng(8);
  std::normal_distribution<double> g(0, 1);
  std::vector<SpillRecord> clustered;
  for (int i = 0; i < 10000; ++i) {
    const double c = 10.0 * double(i % 5);  // 5 Gaussian blobs on a line
    clustered.push_back({c + g(rng), 0.3 * g(rng), 0.3 * g(rng), 1, 0.5f});
  }
  for (const auto& input : {uniform(10000, 1.0, 17), clustered}) {
    const NodeData d = node_data(input);
    const auto pcl = check_meshlets(MeshletBuilderKind::pcl, d, 16);
    const auto oct = check_meshlets(MeshletBuilderKind::octree, d, 16);
    std::printf("  pcl: diag/spacing %.3f mean size %.2f; octree: diag/spacing %.3f mean size %.2f\n",
                pcl.quality.mean_diag_over_spacing(), pcl.quality.mean_size(), oct.quality.mean_diag_over_spacing(),
                oct.quality.mean_size());
    EXPECT_LT(oct.quality.mean_diag_over_spacing(), 1.25 * pcl.quality.mean_diag_over_spacing());
    EXPECT_GT(oct.quality.mean_size(), 0.55 * pcl.quality.mean_size());
    // Both far better than a grouping that ignores space (16 consecutive input indices).
    std::vector<uint32_t> arbitrary(input.size());
    std::iota(arbitrary.begin(), arbitrary.end(), 0u);
    std::vector<double> raw;
    for (const auto& r : input) raw.insert(raw.end(), {r.x, r.y, r.z});
    MeshletQuality bad;
    add_meshlet_quality(raw, arbitrary, std::vector<uint8_t>(input.size() / 16, 16), bad);
    EXPECT_GT(bad.mean_diag_over_spacing(), 3.0 * pcl.quality.mean_diag_over_spacing());
  }
}

// The PCL builder fills the octree leaves from their kd-tree neighbourhoods: nearly every
// meshlet is full, and the meshlets are more compact than cutting the same Morton order into
// runs of 16 (what a fill from the next leaves along the curve, ignoring space, gives at best).
TEST(MeshletQuality, PclBuilderFillsMeshletsMoreCompactlyThanMortonRuns) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> g(0, 1);
  std::vector<SpillRecord> blobs;
  for (int i = 0; i < 10000; ++i) {
    const double c = 6.0 * double(i % 3);
    blobs.push_back({c + g(rng), g(rng), 0.5 * g(rng), 1, 0.5f});
  }
  for (const auto& input : {uniform(10000, 1.0, 23), blobs}) {
    const NodeData d = node_data(input);
    const auto pcl = check_meshlets(MeshletBuilderKind::pcl, d, 16);
    std::vector<uint32_t> morton(input.size());
    std::iota(morton.begin(), morton.end(), 0u);  // node_data's order is the Morton order
    MeshletQuality runs;
    add_meshlet_quality(d.xyz, morton, std::vector<uint8_t>(input.size() / 16, 16), runs);
    std::printf("  pcl: diag/spacing %.3f mean size %.2f; Morton runs of 16: %.3f\n",
                pcl.quality.mean_diag_over_spacing(), pcl.quality.mean_size(), runs.mean_diag_over_spacing());
    EXPECT_GT(pcl.quality.mean_size(), 15.8);
    EXPECT_LT(pcl.quality.mean_diag_over_spacing(), 0.85 * runs.mean_diag_over_spacing());
  }
}

// ---------------------------------------------------------------- quantization

TEST(Quantize, ErrorAtMostHalfStepIncludingDegenerateAndHugeOffsets) {
  std::mt19937_64 rng(8);
  const double offsets[] = {0.0, -3.7, 1e6, -1e6, 1e9};
  const double extents[] = {1e-6, 1.0, 37.5, 1e4};
  QuantError total;
  for (double off : offsets)
    for (double ext : extents) {
      std::uniform_real_distribution<double> u(0, ext);
      std::vector<std::array<double, 3>> pts(2000);
      Box b;
      for (auto& p : pts) {
        p = {off + u(rng), off + u(rng), off + 2.0};  // z degenerate
        b.add(p[0], p[1], p[2]);
      }
      const QuantFrame f = make_frame(b.lo, b.hi);
      EXPECT_EQ(f.step[2], 0.0);
      QuantError e;
      for (const auto& p : pts)
        for (int a = 0; a < 3; ++a) {
          const uint16_t q = quantize(f, a, p[a]);
          e.add(f, a, p[a], q);
          // half a step, plus the rounding of the decoded double (a few ulps of the coordinate)
          const double ulp = std::nextafter(std::abs(p[a]), 1e308) - std::abs(p[a]);
          if (f.step[a] > 0) {
            ASSERT_LE(std::abs(dequantize(f, a, q) - p[a]), 0.5 * f.step[a] + 2 * ulp) << off << " " << ext;
          } else {
            ASSERT_EQ(dequantize(f, a, q), p[a]);
          }
        }
      // the box corners are exact
      EXPECT_EQ(quantize(f, 0, b.lo[0]), 0);
      EXPECT_EQ(quantize(f, 0, b.hi[0]), 65535);
      const double ulp = std::nextafter(std::abs(off) + ext, 1e308) - (std::abs(off) + ext);
      EXPECT_LE(e.max_over_half_step, 1.0 + 4 * ulp / (ext / 65535.0));
      total.merge(e);
    }
  EXPECT_GT(total.max_over_half_step, 0.9);  // the bound is tight: errors do come close to half a step
}

TEST(Quantize, RadiusMapsEndpoints) {
  EXPECT_EQ(quantize_radius(0.5f, 0.5f, 1.5f), 0);
  EXPECT_EQ(quantize_radius(1.5f, 0.5f, 1.5f), 65535);
  EXPECT_EQ(quantize_radius(1.0f, 1.0f, 1.0f), 0);
  const uint16_t q = quantize_radius(1.0f, 0.5f, 1.5f);
  EXPECT_NEAR(0.5 + q * (1.0 / 65535.0), 1.0, 1.0 / 65535.0);
}

// ---------------------------------------------------------------- density

TEST(Density, DimsAreNearCubicAndWithinTarget) {
  const double lo[3] = {0, 0, 0};
  {
    const double hi[3] = {10, 10, 10};
    auto d = choose_density_dims(lo, hi, 1000);
    EXPECT_EQ(d, (std::array<uint32_t, 3>{10, 10, 10}));
  }
  {
    const double hi[3] = {100, 10, 1};
    auto d = choose_density_dims(lo, hi, 1000);
    EXPECT_EQ(d, (std::array<uint32_t, 3>{100, 10, 1}));
  }
  {
    const double hi[3] = {10, 10, 0};  // flat
    auto d = choose_density_dims(lo, hi, 100);
    EXPECT_EQ(d, (std::array<uint32_t, 3>{10, 10, 1}));
  }
  {
    const double hi[3] = {1e6, 1, 1};  // needle
    auto d = choose_density_dims(lo, hi, 8);
    EXPECT_EQ(d, (std::array<uint32_t, 3>{8, 1, 1}));
  }
  {
    const double hi[3] = {0, 0, 0};
    auto d = choose_density_dims(lo, hi, 1000);
    EXPECT_EQ(d, (std::array<uint32_t, 3>{1, 1, 1}));
  }
  std::mt19937 rng(4);
  for (int i = 0; i < 200; ++i) {
    const double hi[3] = {double(1 + rng() % 1000), double(1 + rng() % 1000), double(1 + rng() % 1000)};
    const uint64_t target = 1 + rng() % 2000000;
    auto d = choose_density_dims(lo, hi, target);
    const uint64_t prod = uint64_t(d[0]) * d[1] * d[2];
    EXPECT_LE(prod, target);
    EXPECT_GE(d[0], 1u);
    // close to the target when the box allows (all dims > 1)
    if (d[0] > 4 && d[1] > 4 && d[2] > 4) {
      EXPECT_GT(double(prod), 0.4 * double(target));
      // voxels near cubic
      const double s[3] = {hi[0] / d[0], hi[1] / d[1], hi[2] / d[2]};
      EXPECT_LT(std::max({s[0], s[1], s[2]}) / std::min({s[0], s[1], s[2]}), 1.6);
    }
  }
  EXPECT_EQ(default_density_target(80), 10u);
  EXPECT_EQ(default_density_target(1ull << 40), kDefaultDensityVoxels);
}

TEST(Density, GridIndexAndVoxelRefs) {
  const double lo[3] = {0, 0, 0}, hi[3] = {4, 2, 1};
  DensityGrid g(lo, hi, {4, 2, 1});
  EXPECT_EQ(g.voxel(0, 0, 0), 0u);
  EXPECT_EQ(g.voxel(4, 2, 1), 7u);  // upper bound clamps into the last voxel
  EXPECT_EQ(g.voxel(1.5, 1.5, 0.5), 1u + 4u * 1u);
  EXPECT_EQ(g.voxel(-10, -10, -10), 0u);
  std::vector<uint32_t> v = {5, 1, 5, 7, 1, 1};
  std::vector<store::VoxelRef> refs;
  voxel_refs(v, refs);
  ASSERT_EQ(refs.size(), 3u);
  EXPECT_EQ(refs[0].voxel, 1u);
  EXPECT_EQ(refs[0].count, 3u);
  EXPECT_EQ(refs[1].voxel, 5u);
  EXPECT_EQ(refs[1].count, 2u);
  EXPECT_EQ(refs[2].voxel, 7u);
  EXPECT_EQ(refs[2].count, 1u);
}

TEST(Density, ParsesResolution) {
  auto a = parse_density_res("1000000");
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->target_voxels, 1000000u);
  EXPECT_FALSE(a->explicit_dims);
  auto b = parse_density_res("64x64x32");
  ASSERT_TRUE(b.ok());
  EXPECT_TRUE(b->explicit_dims);
  EXPECT_EQ(b->dims, (std::array<uint32_t, 3>{64, 64, 32}));
  for (const char* bad : {"", "0", "abc", "64x64", "0x1x1", "1x2x3x4", "-5", "100000x100000x100000", "8x8xq"})
    EXPECT_FALSE(parse_density_res(bad).ok()) << bad;
}

// ---------------------------------------------------------------- options

TEST(Options, ParsesByteSizesAndRadii) {
  EXPECT_EQ(*parse_byte_size("512MiB"), 512ull << 20);
  EXPECT_EQ(*parse_byte_size("2GiB"), 2ull << 30);
  EXPECT_EQ(*parse_byte_size("1.5G"), 3ull << 29);
  EXPECT_EQ(*parse_byte_size("8M"), 8ull << 20);
  EXPECT_EQ(*parse_byte_size("65536"), 65536u);
  for (const char* bad : {"", "abc", "12XB", "-1G", "0", "1.2.3M", "G"}) EXPECT_FALSE(parse_byte_size(bad).ok()) << bad;
  auto r = parse_radius_by_type("1=0.5,2=0.7");
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->size(), 2u);
  EXPECT_FLOAT_EQ(r->at(2), 0.7f);
  for (const char* bad : {"1", "1=", "=0.5", "1=0.5,", "a=1", "1=-0.5", "1=nan", "1=0.5x"})
    EXPECT_FALSE(parse_radius_by_type(bad).ok()) << bad;
}

// ---------------------------------------------------------------- spill + binning

TEST(Binning, PartitionsSkewedSpillIntoMortonOrderedBinsAndCleansUp) {
  TmpDir td;
  std::filesystem::path tmp_path;
  std::mt19937_64 rng(12);
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> u(0, 1000);
  std::vector<SpillRecord> recs;
  for (int i = 0; i < 120000; ++i) {
    if (i % 10 == 0) recs.push_back({u(rng), u(rng), u(rng), 1, 0.5f});
    else recs.push_back({500 + g(rng), 500 + g(rng), 500 + g(rng), 2, 0.5f});  // 90% in a tiny blob
  }
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (const auto& r : recs) {
    lo[0] = std::min(lo[0], r.x), hi[0] = std::max(hi[0], r.x);
    lo[1] = std::min(lo[1], r.y), hi[1] = std::max(hi[1], r.y);
    lo[2] = std::min(lo[2], r.z), hi[2] = std::max(hi[2], r.z);
  }
  MortonGrid grid(lo, hi);
  {
    TempDir tmp(td.p);
    auto spill_path = tmp.file("spill.rec");
    ASSERT_TRUE(spill_path.ok());
    tmp_path = tmp.dir();
    auto w = SpillWriter::create(*spill_path, 4096);
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE(w->append(recs).ok());
    ASSERT_TRUE(w->close().ok());
    PartitionOptions opt;
    opt.max_bin_records = 5000;
    opt.buffer_bytes = 256 << 10;
    PartitionStats stats;
    uint64_t reported = 0;
    auto bins = partition(tmp, Bin{*spill_path, recs.size(), 0, 0}, grid, opt, stats,
                          [&](uint64_t n) { reported += n; });
    ASSERT_TRUE(bins.ok()) << bins.error().message;
    EXPECT_FALSE(std::filesystem::exists(*spill_path));
    EXPECT_GT(stats.passes, 1u);  // the blob forced recursive re-splitting
    EXPECT_EQ(reported, stats.records_read);
    uint64_t total = 0;
    uint64_t prev_end = 0;  // bins are disjoint key ranges in increasing order
    for (const auto& b : *bins) {
      EXPECT_LE(b.count, opt.max_bin_records);
      EXPECT_EQ(b.prefix_bits % 3, 0);
      const uint64_t begin = b.prefix << (kMortonBits - b.prefix_bits);
      const uint64_t end = (b.prefix + 1) << (kMortonBits - b.prefix_bits);
      EXPECT_GE(begin, prev_end);
      prev_end = end;
      auto rd = SpillReader::open(b.path);
      ASSERT_TRUE(rd.ok());
      EXPECT_EQ(rd->count(), b.count);
      std::vector<SpillRecord> chunk(1000);
      for (;;) {
        auto n = rd->read(chunk);
        ASSERT_TRUE(n.ok());
        if (*n == 0) break;
        for (size_t i = 0; i < *n; ++i)
          ASSERT_EQ(morton_prefix(grid.key(chunk[i].x, chunk[i].y, chunk[i].z), b.prefix_bits), b.prefix);
      }
      total += b.count;
    }
    EXPECT_EQ(total, recs.size());
  }
  EXPECT_FALSE(std::filesystem::exists(tmp_path));  // TempDir removed everything
  EXPECT_TRUE(std::filesystem::is_empty(td.p));
}
