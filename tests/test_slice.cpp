// Slices (store/slice.h, `--slice` of render, view and bench): the spec's syntax, which centres a
// slice keeps (half-space, slab, inverted), the box test that lets load_scene skip whole nodes
// against the point test, load_scene's filter, and `mdstream render --slice` end to end: the
// image equals that of a store converted from just the kept particles, and the culled view
// converges to its every-particle reference.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "render/scene.h"
#include "store/slice.h"

using namespace mds;
using store::Slice;
using store::SliceCover;
using mds::testing::compare_exr;
using mds::testing::ExrDifference;
namespace fs = std::filesystem;

TEST(Slice, ParsesNormalDistanceWidthAndInvert) {
  auto a = store::parse_slice("0,0,2,5");
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_EQ(a->normal, (std::array<double, 3>{0.0, 0.0, 1.0}));  // normalized
  EXPECT_EQ(a->distance, 5.0);  // along the unit normal, as OVITO's Distance
  EXPECT_EQ(a->width, 0.0);
  EXPECT_FALSE(a->invert);
  auto b = store::parse_slice(" 3, 4 ,0 , -1.5, 2 ,invert ");
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_DOUBLE_EQ(b->normal[0], 0.6);
  EXPECT_DOUBLE_EQ(b->normal[1], 0.8);
  EXPECT_EQ(b->distance, -1.5);
  EXPECT_EQ(b->width, 2.0);
  EXPECT_TRUE(b->invert);
  auto c = store::parse_slice("1,0,0,+7,invert");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->width, 0.0);
  EXPECT_TRUE(c->invert);
  // The spec reads back as the same slice.
  for (const Slice& s : {*a, *b, *c}) {
    auto again = store::parse_slice(store::slice_spec(s));
    ASSERT_TRUE(again.ok()) << store::slice_spec(s);
    EXPECT_EQ(*again, s) << store::slice_spec(s);
  }
  // An option given once per slice: all of them in order, or the first error under the option's name.
  const std::vector<std::string> two = {"0,0,2,5", " 3, 4 ,0 , -1.5, 2 ,invert "};
  auto both = store::parse_slices(two);
  ASSERT_TRUE(both.ok()) << both.error().message;
  EXPECT_EQ(*both, (std::vector<Slice>{*a, *b}));
  const std::vector<std::string> bad_second = {"0,0,2,5", "1,0", "0,0,0,1"};
  auto e = store::parse_slices(bad_second);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().message.rfind("--slice '1,0'", 0), 0u) << e.error().message;
  for (const char* bad : {"", "1,0,0", "1,0,0,1,2,3", "0,0,0,1", "1,0,0,x", "1,0,0,1,-1", "nan,0,0,1",
                          "1,0,0,inf", "1e308,1e308,0,1", "1,0,0,1,invert,invert", "1,,0,1", "invert"}) {
    auto r = store::parse_slice(bad);
    ASSERT_FALSE(r.ok()) << "'" << bad << "'";
    EXPECT_NE(r.error().message.find(std::string("'") + bad + "'"), std::string::npos) << r.error().message;
  }
}

TEST(Slice, KeepsTheNegativeSideTheSlabOrTheirComplement) {
  const Slice half{{1.0, 0.0, 0.0}, 2.0, 0.0, false};
  EXPECT_TRUE(store::slice_keeps(half, {1.0, 5.0, -5.0}));
  EXPECT_TRUE(store::slice_keeps(half, {2.0, 0.0, 0.0}));  // on the plane: kept
  EXPECT_FALSE(store::slice_keeps(half, {2.5, 0.0, 0.0}));
  Slice inverted = half;
  inverted.invert = true;
  for (double x : {1.0, 2.0, 2.0000001, 3.0})
    EXPECT_NE(store::slice_keeps(half, {x, 0, 0}), store::slice_keeps(inverted, {x, 0, 0})) << x;
  const Slice slab{{0.0, 0.0, -1.0}, 1.0, 0.5, false};  // -z = 1 +- 0.25: z in [-1.25, -0.75]
  EXPECT_TRUE(store::slice_keeps(slab, {9, 9, -1.0}));
  EXPECT_TRUE(store::slice_keeps(slab, {9, 9, -0.75}));
  EXPECT_TRUE(store::slice_keeps(slab, {9, 9, -1.25}));
  EXPECT_FALSE(store::slice_keeps(slab, {9, 9, -0.7}));
  EXPECT_FALSE(store::slice_keeps(slab, {9, 9, -1.3}));
  Slice cut = slab;
  cut.invert = true;  // everything but the slab
  EXPECT_FALSE(store::slice_keeps(cut, {9, 9, -1.0}));
  EXPECT_TRUE(store::slice_keeps(cut, {9, 9, 5.0}));
  // Several slices keep what each keeps; none keep everything.
  const std::vector<Slice> both = {half, slab};
  EXPECT_TRUE(store::slices_keep(both, {1.0, 0.0, -1.0}));
  EXPECT_FALSE(store::slices_keep(both, {3.0, 0.0, -1.0}));
  EXPECT_FALSE(store::slices_keep(both, {1.0, 0.0, 0.0}));
  EXPECT_TRUE(store::slices_keep({}, {1e300, 0.0, 0.0}));
}

// The box test agrees with the point test for every point of the box, also on its boundary:
// boxes and points on a grid of quantized values, planes through grid points (t == 0 exactly,
// |t| == w/2 exactly), oblique normals, slabs and inverted slices.
TEST(Slice, BoxCoverAgreesWithEveryPointInside) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> grid(0, 8);
  const double g = 0.125;
  size_t counts[3] = {0, 0, 0};
  for (int trial = 0; trial < 4000; ++trial) {
    std::vector<Slice> slices;
    const int n = 1 + trial % 2;
    for (int k = 0; k < n; ++k) {
      Slice s;
      const int kind = int(rng() % 3);
      if (kind == 0) {  // axis-aligned through a grid value
        const int axis = int(rng() % 3);
        s.normal = {0, 0, 0};
        s.normal[size_t(axis)] = rng() % 2 ? 1.0 : -1.0;
        s.distance = s.normal[size_t(axis)] * g * grid(rng);
      } else {
        std::normal_distribution<double> d;
        std::array<double, 3> v{d(rng), d(rng), kind == 1 ? 0.0 : d(rng)};
        const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        s.normal = {v[0] / len, v[1] / len, v[2] / len};
        s.distance = g * grid(rng) * 0.7;
      }
      s.width = rng() % 2 ? 0.0 : g * (1 + grid(rng));
      s.invert = rng() % 3 == 0;
      slices.push_back(s);
    }
    std::array<int, 3> a{}, b{};
    for (int k = 0; k < 3; ++k) {
      a[size_t(k)] = grid(rng);
      b[size_t(k)] = std::min(8, a[size_t(k)] + int(rng() % 4));
    }
    const std::array<double, 3> lo{g * a[0], g * a[1], g * a[2]}, hi{g * b[0], g * b[1], g * b[2]};
    const SliceCover cover = store::slices_cover(slices, lo, hi);
    ++counts[int(cover)];
    size_t kept = 0, total = 0;
    for (int x = a[0]; x <= b[0]; ++x)
      for (int y = a[1]; y <= b[1]; ++y)
        for (int z = a[2]; z <= b[2]; ++z) {
          kept += store::slices_keep(slices, {g * x, g * y, g * z});
          ++total;
        }
    if (cover == SliceCover::all) {
      EXPECT_EQ(kept, total) << trial;
    } else if (cover == SliceCover::none) {
      EXPECT_EQ(kept, 0u) << trial;
    }
  }
  // Every outcome occurs.
  EXPECT_GT(counts[int(SliceCover::none)], 200u);
  EXPECT_GT(counts[int(SliceCover::all)], 200u);
  EXPECT_GT(counts[int(SliceCover::some)], 200u);
}

// load_scene's filter with slices: the particles whose centre, decoded as append_node decodes it,
// every slice keeps, meshlet by meshlet, with types, radii and the property alongside; the node's
// decoded box covers every centre it can decode to, including q = 65535.
TEST(Slice, FilterKeepsDecodedCentresMeshletByMeshlet) {
  store::NodeData in;
  in.meshlet_size = {4, 3, 2};
  const uint16_t q[9] = {0, 100, 65535, 30000, 65535, 200, 40000, 65535, 1};
  for (int i = 0; i < 9; ++i) {
    in.qpos.insert(in.qpos.end(), {q[i], uint16_t(i), 0});
    in.type_index.push_back(uint8_t(i % 2));
    in.radius_q.push_back(uint16_t(10 + i));
    in.property_q.push_back(uint16_t(20 + i));
  }
  const double cmin[3] = {1.0, 2.0, 3.0}, cmax[3] = {1.3, 2.5, 3.0};  // an odd step: 0.3 / 65535
  std::array<double, 3> lo, hi;
  store::decoded_box(cmin, cmax, lo, hi);
  const double step = (cmax[0] - cmin[0]) / 65535.0;
  const double top = cmin[0] + 65535.0 * step;
  EXPECT_EQ(hi[0], std::max(top, cmin[0]));
  // A plane exactly through the centre with q = 65535: kept (t == 0), the box cover is `all`.
  const std::vector<Slice> at_top = {Slice{{1, 0, 0}, top, 0.0, false}};
  EXPECT_EQ(store::slices_cover(at_top, lo, hi), SliceCover::all);
  // A plane through q = 30000: 0, 100, 30000, 200 and 1 kept (30000 on the plane), the rest not.
  const std::vector<Slice> mid = {Slice{{1, 0, 0}, cmin[0] + 30000.0 * step, 0.0, false}};
  EXPECT_EQ(store::slices_cover(mid, lo, hi), SliceCover::some);
  store::NodeData out;
  render::filter_particles(in, render::ParticleFilter{{}, mid, cmin, cmax}, out);
  EXPECT_EQ(out.meshlet_size, (std::vector<uint8_t>{3, 1, 1}));
  EXPECT_EQ(out.type_index, (std::vector<uint8_t>{0, 1, 1, 1, 0}));
  EXPECT_EQ(out.radius_q, (std::vector<uint16_t>{10, 11, 13, 15, 18}));
  EXPECT_EQ(out.property_q, (std::vector<uint16_t>{20, 21, 23, 25, 28}));
  EXPECT_EQ(out.qpos, (std::vector<uint16_t>{0, 0, 0, 100, 1, 0, 30000, 3, 0, 200, 5, 0, 1, 8, 0}));
  // With the types too: type 1 left out.
  const std::vector<uint8_t> shown = {1, 0};
  render::filter_particles(in, render::ParticleFilter{shown, mid, cmin, cmax}, out);
  EXPECT_EQ(out.meshlet_size, (std::vector<uint8_t>{1, 1}));
  EXPECT_EQ(out.type_index, (std::vector<uint8_t>{0, 0}));
  // Slices without the node's frame: passed on whole (a caller's mistake, not a silent drop).
  render::filter_particles(in, render::ParticleFilter{{}, mid, nullptr, nullptr}, out);
  EXPECT_EQ(out.type_index, in.type_index);
}

namespace {

int run(const std::string& args) { return mds::testing::run_mdstream(args); }
std::string last_stderr() { return mds::testing::cli_stderr(); }

class SliceCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mds_slice_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    ASSERT_EQ(run("synth --scene porous --particles 20000 -q -o " + (dir_ / "p.lammpstrj").string()), 0)
        << last_stderr();
    ASSERT_EQ(run("convert " + (dir_ / "p.lammpstrj").string() + " -q -o " + store()), 0) << last_stderr();
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string store() { return (dir_ / "p.mds").string(); }
  static fs::path dir_;
};
fs::path SliceCli::dir_;

// The particles of `xyz` (as `mdstream export` writes it: species x y z) that the slices keep,
// written as an XYZ file; the count.
size_t write_kept(const fs::path& xyz, const std::vector<Slice>& slices, const fs::path& out) {
  std::ifstream in(xyz);
  std::string line;
  std::getline(in, line);  // count
  std::getline(in, line);  // comment
  std::vector<std::string> kept;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string species;
    std::array<double, 3> p{};
    ls >> species >> p[0] >> p[1] >> p[2];
    if (ls && store::slices_keep(slices, p)) kept.push_back(line);
  }
  std::ofstream o(out);
  o << kept.size() << "\nProperties=species:S:1:pos:R:3\n";
  for (const std::string& l : kept) o << l << "\n";
  return kept.size();
}

double stats_particles(const fs::path& json) {
  return nlohmann::json::parse(std::ifstream(json)).at("particles").get<double>();
}

}  // namespace

// A sliced render draws exactly the particles the slices keep: the same count, and the same image
// as the store converted from only those particles (the exported centres filtered here), seen
// from the same camera in the same colours. Both renders draw every particle. `export --slice`
// writes the same particles.
TEST_F(SliceCli, DrawsWhatAStoreOfTheKeptParticlesDraws) {
  ASSERT_EQ(run("export " + store() + " -o " + (dir_ / "all.xyz").string()), 0) << last_stderr();
  const std::vector<std::string> specs = {"1,1,0,22", "0,0,1,9,6", "0,1,0,4,invert"};
  std::vector<Slice> slices;
  std::string args;
  for (const std::string& s : specs) {
    auto p = store::parse_slice(s);
    ASSERT_TRUE(p.ok()) << p.error().message;
    slices.push_back(*p);
    args += " --slice " + s;
  }
  const size_t kept = write_kept(dir_ / "all.xyz", slices, dir_ / "kept.xyz");
  ASSERT_GT(kept, 1000u);
  ASSERT_LT(kept, 10000u);
  // `export --slice` writes those particles, line for line.
  ASSERT_EQ(run("export " + store() + " -o " + (dir_ / "sliced.xyz").string() + args), 0) << last_stderr();
  {
    std::ifstream a(dir_ / "kept.xyz"), b(dir_ / "sliced.xyz");
    std::string la, lb;
    size_t line = 0;
    while (std::getline(a, la)) {
      ASSERT_TRUE(std::getline(b, lb)) << "line " << line;
      if (line != 1) {  // line 1: the Properties comments differ
        EXPECT_EQ(la, lb) << "line " << line;
      }
      ++line;
    }
    EXPECT_FALSE(std::getline(b, lb)) << "more lines than kept";
  }
  ASSERT_EQ(run("convert " + (dir_ / "kept.xyz").string() + " -q -o " + (dir_ / "kept.mds").string()), 0)
      << last_stderr();
  const std::string look = " --no-cull --spp 4 --width 96 --height 72 --camera 40,-30,35,14,14,12 --background 0,0,0 --cell off "
                           "--type-color 1=#e15759 --type-color 2=#4e79a7";
  ASSERT_EQ(run("render " + store() + " -o " + (dir_ / "sliced.exr").string() + look + args + " --stats " +
                (dir_ / "sliced.json").string()),
            0)
      << last_stderr();
  ASSERT_EQ(run("render " + (dir_ / "kept.mds").string() + " -o " + (dir_ / "kept.exr").string() + look +
                " --stats " + (dir_ / "kept.json").string()),
            0)
      << last_stderr();
  EXPECT_EQ(stats_particles(dir_ / "sliced.json"), double(kept));
  EXPECT_EQ(stats_particles(dir_ / "kept.json"), double(kept));
  const nlohmann::json stats = nlohmann::json::parse(std::ifstream(dir_ / "sliced.json"));
  EXPECT_EQ(stats.at("slices").size(), specs.size());
  // The two stores' quantization frames differ: a few pixels may.
  const ExrDifference d = compare_exr(dir_ / "sliced.exr", dir_ / "kept.exr", 96, 72);
  EXPECT_GT(d.covered, size_t(96 * 72) / 10);
  EXPECT_LE(d.differing, size_t(96 * 72) / 200) << d.differing << " of " << d.covered << " covered pixels";
  // Without the slices the image differs: the slices did something visible.
  ASSERT_EQ(run("render " + store() + " -o " + (dir_ / "whole.exr").string() + look), 0) << last_stderr();
  EXPECT_GT(compare_exr(dir_ / "sliced.exr", dir_ / "whole.exr", 96, 72).differing, size_t(96 * 72) / 20);
}

// Culled, the interior a slice opens converges to its every-particle reference: the occluders,
// the node and meshlet boxes and the density volume are those of the kept particles. A slice
// that keeps nothing (in memory or streaming) or a malformed one is a usage error without output.
TEST_F(SliceCli, CulledSliceMatchesItsReferenceAndErrorsAreUsage) {
  const fs::path json = dir_ / "bench.json";
  ASSERT_EQ(run("bench " + store() + " --view 1 --width 64 --height 48 --slice 1,1,0,22 --spp-list 4 "
                "--reference-spp 4 --coverage exact --json " + json.string() + " > /dev/null"),
            0)
      << last_stderr();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  size_t checked = 0;
  for (const auto& r : j.at("rows")) {
    if (r.at("mode").get<std::string>() != "culled") continue;
    ++checked;
    EXPECT_TRUE(r.at("converged").get<bool>());
    EXPECT_LE(r.at("differing_fraction").get<double>(), 0.01) << r.dump();
  }
  EXPECT_EQ(checked, 1u) << j.dump();

  const fs::path png = dir_ / "bad.png";
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --slice 1,0,0,-100"), 2);
  EXPECT_NE(last_stderr().find("--slice leaves no particle"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --slice 1,0,0"), 2);
  EXPECT_NE(last_stderr().find("--slice '1,0,0'"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --slice 1,0,0,-100 --gpu-budget 64MiB"), 2);
  EXPECT_NE(last_stderr().find("--slice leaves no particle"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --slice 1,0,0,5 --visible-reference"), 2);
  EXPECT_NE(last_stderr().find("--slice"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(png));
  const fs::path xyz = dir_ / "bad.xyz";
  EXPECT_EQ(run("export " + store() + " -o " + xyz.string() + " --slice 1,0,0,-100"), 2);
  EXPECT_NE(last_stderr().find("--slice leaves no particle"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("export " + store() + " -o " + xyz.string() + " --slice 1,0,0,5,-2"), 2);
  EXPECT_NE(last_stderr().find("WIDTH must be >= 0"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(xyz));
}

// Streaming (--gpu-budget below the store's pool pages): the nodes the slab leaves out whole are
// never read, the cut nodes lose their cut particles on the reader threads, and the converged,
// culled image equals the in-memory sliced render that draws every particle. Nodes of 500
// particles (60 nodes), a 6-unit slab across z.
TEST_F(SliceCli, StreamedSliceReadsOnlyWhatItKeepsAndMatchesInMemory) {
  const std::string small = (dir_ / "p500.mds").string();
  ASSERT_EQ(run("convert " + (dir_ / "p.lammpstrj").string() + " -q --node-size 500 -o " + small), 0) << last_stderr();
  const std::string look = " --spp 4 --width 96 --height 72 --camera 40,-30,35,14,14,12 --background 0,0,0 "
                           "--slice 0,0,1,9,6";
  const fs::path mem_json = dir_ / "mem.json";
  ASSERT_EQ(run("render " + small + " --no-cull -o " + (dir_ / "mem.exr").string() + look + " --stats " + mem_json.string()),
            0)
      << last_stderr();
  const fs::path json = dir_ / "streamed.json";
  ASSERT_EQ(run("render " + small + " --gpu-budget 200KiB -o " + (dir_ / "streamed.exr").string() + look +
                " --stats " + json.string()),
            0)
      << last_stderr();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  EXPECT_TRUE(j.at("converged").get<bool>());
  EXPECT_FALSE(j.at("budget_exhausted").get<bool>());
  EXPECT_LE(j.at("gpu_peak_bytes").get<uint64_t>(), j.at("gpu_budget_bytes").get<uint64_t>());
  const uint64_t sliced_out = j.at("nodes_left_out").get<uint64_t>();
  EXPECT_GT(sliced_out, 10u);  // the slab crosses a third of the 60 nodes
  EXPECT_GE(j.at("nodes_never_loaded").get<uint64_t>(), sliced_out);
  EXPECT_LT(j.at("bytes_read").get<uint64_t>(), j.at("store_payload_bytes").get<uint64_t>() * 3 / 4);
  EXPECT_TRUE(j.at("node_errors").empty());
  // The classification counts only the nodes the slab keeps (GpuNode::flags kGpuNodeLeftOut).
  uint64_t classified = 0;
  for (const auto& [cls, count] : j.at("node_class_counts").items()) classified += count.get<uint64_t>();
  EXPECT_EQ(classified, j.at("nodes").get<uint64_t>() - sliced_out);
  // The pool holds every node the slab keeps: streamed without culling (which reads every kept
  // node in view, whatever order they arrive in), the resident nodes and their meshlets are the
  // in-memory scene's (a cut node counts the meshlets it kept). Culled, a node found occluded
  // before its read is never read: at most those.
  const nlohmann::json mem = nlohmann::json::parse(std::ifstream(mem_json));
  const fs::path all_json = dir_ / "streamed_all.json";
  ASSERT_EQ(run("render " + small + " --no-cull --gpu-budget 200KiB -o " + (dir_ / "streamed_all.exr").string() + look +
                " --stats " + all_json.string()),
            0)
      << last_stderr();
  const nlohmann::json all = nlohmann::json::parse(std::ifstream(all_json));
  EXPECT_EQ(all.at("nodes_resident").get<uint64_t>(), mem.at("nodes").get<uint64_t>());
  EXPECT_EQ(all.at("meshlets").get<uint64_t>(), mem.at("meshlets").get<uint64_t>());
  EXPECT_LE(j.at("nodes_resident").get<uint64_t>(), mem.at("nodes").get<uint64_t>());
  EXPECT_LE(j.at("meshlets").get<uint64_t>(), mem.at("meshlets").get<uint64_t>());
  const ExrDifference d = compare_exr(dir_ / "mem.exr", dir_ / "streamed.exr", 96, 72);
  EXPECT_GT(d.covered, size_t(96 * 72) / 10);
  EXPECT_LE(d.differing, size_t(96 * 72) / 100) << d.differing << " of " << d.covered << " covered pixels";
}

// A node whose box straddles the slice but none of whose particles it keeps is found out only when
// read: from then on it is sliced out like a node whose box lies outside, never read again, and
// no longer classified (the renderer patches its flag into the device's node directory). Nodes
// of particles on the diagonal x = y keep nothing of x - y <= -1, though their boxes reach it;
// the block at y - x ~ 15 is kept whole.
TEST_F(SliceCli, NodeEmptiedWhenReadLeavesTheClassification) {
  const fs::path xyz = dir_ / "diagonal.xyz";
  {
    std::ofstream o(xyz);
    o << 2000 << "\nProperties=species:S:1:pos:R:3\n";
    for (int i = 0; i < 1000; ++i) {
      const double t = 0.01 * i;
      o << "A " << t << " " << t << " " << 0.5 * t << "\n";
    }
    for (int i = 0; i < 1000; ++i) o << "B " << (i % 10) * 0.5 << " " << 20 + (i / 10 % 10) * 0.5 << " " << (i / 100) * 0.5 << "\n";
  }
  const std::string diag = (dir_ / "diagonal.mds").string();
  ASSERT_EQ(run("convert " + xyz.string() + " -q --node-size 250 --radius 0.2 -o " + diag), 0) << last_stderr();
  const std::string look = " --spp 2 --width 64 --height 48 --background 0,0,0 --slice 1,-1,0,-0.7071";
  ASSERT_EQ(run("render " + diag + " --no-cull -o " + (dir_ / "diag_mem.exr").string() + look), 0) << last_stderr();
  const fs::path json = dir_ / "diag.json";
  ASSERT_EQ(run("render " + diag + " --gpu-budget 100KiB -o " + (dir_ / "diag.exr").string() + look + " --stats " +
                json.string()),
            0)
      << last_stderr();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  EXPECT_TRUE(j.at("converged").get<bool>());
  const uint64_t nodes = j.at("nodes").get<uint64_t>(), sliced_out = j.at("nodes_left_out").get<uint64_t>();
  EXPECT_GE(sliced_out, 3u);  // the diagonal's 1000 particles: 4 nodes of 250
  EXPECT_LT(sliced_out, nodes);
  uint64_t classified = 0;
  for (const auto& [cls, count] : j.at("node_class_counts").items()) classified += count.get<uint64_t>();
  EXPECT_EQ(classified, nodes - sliced_out);
  // Within the renderer's tolerance: the streamed culling's classes follow the nodes' arrival order.
  const ExrDifference d = compare_exr(dir_ / "diag_mem.exr", dir_ / "diag.exr", 64, 48);
  EXPECT_GT(d.covered, 0u);
  EXPECT_LE(d.differing, size_t(64 * 48) / 200) << d.differing << " of " << d.covered << " covered pixels";
}
