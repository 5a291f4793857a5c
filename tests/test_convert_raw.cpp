// Conversion of raw float32 xyz input: in memory the converter validates and builds straight
// from the mapped file (convert/record_view.h); with a small budget the same input goes
// through records, spill files and bins. Both stores must decode to every input particle
// (within the reported quantization error), and a non-finite coordinate must be reported with
// its particle and byte offset, leaving no output.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "convert/converter.h"
#include "store/store_reader.h"
#include "scoped_temp_dir.h"

using namespace mds;
namespace fs = std::filesystem;

namespace {

struct TmpDir : mds::test::ScopedTempDir {
  TmpDir() : ScopedTempDir("mds_convert_raw_") {}
};

constexpr double kSpacing = 0.01;
using Site = std::tuple<int64_t, int64_t, int64_t>;

// Distinct lattice sites (a dense block and a sparse halo) as float32 xyz.
std::vector<float> make_xyz(size_t n, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::set<Site> used;
  std::vector<float> xyz;
  while (used.size() < n) {
    const bool dense = rng() % 4 != 0;
    const int64_t ix = dense ? int64_t(rng() % 1500) : -3000 + int64_t(rng() % 8000);
    const int64_t iy = dense ? int64_t(rng() % 1500) : -3000 + int64_t(rng() % 8000);
    const int64_t iz = dense ? int64_t(rng() % 1500) : int64_t(rng() % 5000);
    if (!used.insert({ix, iy, iz}).second) continue;
    xyz.insert(xyz.end(), {float(double(ix) * kSpacing), float(double(iy) * kSpacing), float(double(iz) * kSpacing)});
  }
  return xyz;
}

void write_raw(const fs::path& p, const std::vector<float>& xyz) {
  FILE* f = std::fopen(p.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(std::fwrite(xyz.data(), sizeof(float), xyz.size(), f), xyz.size());
  std::fclose(f);
}

// Every input particle decodes back exactly once, within the store's maximum error.
void check_store(const fs::path& path, const std::vector<float>& xyz, float radius) {
  auto rd = store::StoreReader::open(path);
  ASSERT_TRUE(rd.ok()) << rd.error().message;
  const auto& h = (*rd)->header();
  const size_t n = xyz.size() / 3;
  ASSERT_EQ(h.particle_count, n);
  EXPECT_LE(h.max_error_over_half_step, 1.0 + 1e-6);
  ASSERT_EQ((*rd)->types().size(), 1u);
  EXPECT_EQ((*rd)->types()[0].input_id, 1);
  EXPECT_FLOAT_EQ((*rd)->types()[0].radius, radius);
  std::map<Site, size_t> sites;
  for (size_t i = 0; i < n; ++i)
    sites[{std::llround(xyz[3 * i] / kSpacing), std::llround(xyz[3 * i + 1] / kSpacing),
           std::llround(xyz[3 * i + 2] / kSpacing)}] = i;
  std::vector<uint8_t> seen(n, 0);
  store::NodeData nd;
  std::vector<uint8_t> scratch;
  double max_err = 0;
  for (uint32_t i = 0; i < (*rd)->nodes().size(); ++i) {
    const auto& e = (*rd)->nodes()[i];
    ASSERT_TRUE((*rd)->read_node(i, nd, scratch).ok());
    for (size_t k = 0; k < nd.particle_count(); ++k) {
      double p[3];
      for (int a = 0; a < 3; ++a) p[a] = e.center_min[a] + double(nd.qpos[3 * k + a]) * store::quant_step(e, a);
      auto it = sites.find({std::llround(p[0] / kSpacing), std::llround(p[1] / kSpacing), std::llround(p[2] / kSpacing)});
      ASSERT_NE(it, sites.end()) << "decoded particle " << p[0] << " " << p[1] << " " << p[2] << " not in the input";
      ASSERT_EQ(seen[it->second], 0) << "input particle decoded twice";
      seen[it->second] = 1;
      for (int a = 0; a < 3; ++a) max_err = std::max(max_err, std::abs(p[a] - double(xyz[3 * it->second + a])));
    }
  }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), ptrdiff_t(n));
  EXPECT_LE(max_err, h.max_quantization_error * (1 + 1e-9) + 1e-12);
}

}  // namespace

TEST(ConvertRaw, MappedInMemoryAndOutOfCoreBothRoundTrip) {
  TmpDir td;
  const auto xyz = make_xyz(150000, 7);
  write_raw(td.p / "in.raw", xyz);
  convert::ConvertOptions opt;
  opt.inputs = {td.p / "in.raw"};
  opt.reader.format = InputFormat::raw;
  opt.output = td.p / "mem.mds";
  opt.node_size = 2000;
  opt.radius_by_type = {{1, 0.7f}};
  opt.density.target_voxels = 4096;
  auto rep = convert::convert(opt);
  ASSERT_TRUE(rep.ok()) << rep.error().message;
  EXPECT_FALSE(rep->spilled);
  EXPECT_EQ(rep->particles, xyz.size() / 3);
  check_store(opt.output, xyz, 0.7f);
  for (const auto builder : {convert::MeshletBuilderKind::pcl, convert::MeshletBuilderKind::octree}) {
    opt.meshlet_builder = builder;
    opt.output = td.p / "ooc.mds";
    opt.memory_budget = 2u << 20;  // below the 4.8 MB of records: spill files and bins
    auto rep2 = convert::convert(opt);
    ASSERT_TRUE(rep2.ok()) << rep2.error().message;
    EXPECT_TRUE(rep2->spilled);
    check_store(opt.output, xyz, 0.7f);
  }
  opt.memory_budget = convert::kDefaultMemoryBudget;
  opt.threads = 1;  // single-threaded validation and build give the same store
  opt.meshlet_builder = convert::MeshletBuilderKind::pcl;
  opt.output = td.p / "mem1.mds";
  ASSERT_TRUE(convert::convert(opt).ok());
  std::ifstream a(td.p / "mem.mds", std::ios::binary), b(td.p / "mem1.mds", std::ios::binary);
  const std::string sa((std::istreambuf_iterator<char>(a)), {}), sb((std::istreambuf_iterator<char>(b)), {});
  EXPECT_TRUE(sa == sb);
}

TEST(ConvertRaw, FirstNonFiniteCoordinateNamesParticleAndByteOffset) {
  TmpDir td;
  auto xyz = make_xyz(100000, 8);  // two validation threads: the bad values lie in the second half
  xyz[3 * 70000 + 2] = std::numeric_limits<float>::infinity();
  xyz[3 * 90000 + 0] = std::numeric_limits<float>::quiet_NaN();
  write_raw(td.p / "bad.raw", xyz);
  convert::ConvertOptions opt;
  opt.inputs = {td.p / "bad.raw"};
  opt.reader.format = InputFormat::raw;
  opt.output = td.p / "bad.mds";
  auto rep = convert::convert(opt);
  ASSERT_FALSE(rep.ok());
  const std::string& m = rep.error().message;
  EXPECT_NE(m.find("bad.raw"), std::string::npos) << m;
  EXPECT_NE(m.find("byte offset " + std::to_string(70000 * 12 + 8)), std::string::npos) << m;
  EXPECT_NE(m.find("particle 70000"), std::string::npos) << m;
  EXPECT_EQ(std::distance(fs::directory_iterator(td.p), fs::directory_iterator{}), 1);  // only the input
}

// The mapped path takes bounds with SSE2 lanes, which meet equal values in another order than
// the records' scalar loop; only +0 and -0 (equal, different bits) can tell. The stores' bounds
// must have the same bits either way: with +0 alone (a box from 0, the common case, where no
// second pass runs), with -0 alone and with both in either order.
TEST(ConvertRaw, ZeroBoundsHaveTheSameBitsOnBothPaths) {
  TmpDir td;
  const float pz = 0.0f, nz = -0.0f;
  // (value, particle) pairs: particle 43 is in lane group 3 of a 4-particle SSE2 block and 1200
  // in group 0, so the lanes' reduction meets the later zero first.
  using Zeros = std::vector<std::pair<float, size_t>>;
  const std::vector<Zeros> zeros = {{{pz, 43}}, {{nz, 43}}, {{pz, 43}, {nz, 1200}}, {{nz, 43}, {pz, 1200}},
                                    {{pz, 43}, {pz, 500}, {nz, 1200}}};
  for (size_t c = 0; c < zeros.size(); ++c) {
    auto xyz = make_xyz(150000, uint32_t(11 + c));
    // A positive box: the zeros are the lowest x.
    for (auto& v : xyz) v = std::abs(v) + 1.0f;
    for (const auto& [v, i] : zeros[c]) xyz[3 * i] = v;
    write_raw(td.p / "z.raw", xyz);
    convert::ConvertOptions opt;
    opt.inputs = {td.p / "z.raw"};
    opt.reader.format = InputFormat::raw;
    opt.meshlet_builder = convert::MeshletBuilderKind::octree;
    opt.node_size = 2000;
    opt.density.target_voxels = 4096;
    opt.output = td.p / "mapped.mds";
    auto a = convert::convert(opt);
    ASSERT_TRUE(a.ok()) << a.error().message;
    EXPECT_FALSE(a->spilled);
    opt.output = td.p / "records.mds";
    opt.memory_budget = 2u << 20;  // below the 4.8 MB of records: the scalar loop of pass A
    auto b = convert::convert(opt);
    ASSERT_TRUE(b.ok()) << b.error().message;
    EXPECT_TRUE(b->spilled);
    auto ra = store::StoreReader::open(td.p / "mapped.mds");
    auto rb = store::StoreReader::open(td.p / "records.mds");
    ASSERT_TRUE(ra.ok() && rb.ok());
    for (int ax = 0; ax < 3; ++ax) {
      EXPECT_EQ(std::signbit((*ra)->header().bounds_min[ax]), std::signbit((*rb)->header().bounds_min[ax]))
          << "case " << c << " axis " << ax;
      EXPECT_EQ((*ra)->header().bounds_min[ax], (*rb)->header().bounds_min[ax]);
      EXPECT_EQ((*ra)->header().bounds_max[ax], (*rb)->header().bounds_max[ax]);
    }
    EXPECT_EQ((*ra)->header().bounds_min[0], 0.0);
  }
}
