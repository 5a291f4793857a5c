// Thresholds (store/threshold.h, `--threshold` of render, view, bench and export): the spec's
// syntax, which values a threshold keeps (closed interval, open ends, inverted), load_scene's
// filter, and end to end on LAMMPS' own output: a crystal with a spherical void
// (tests/data/lammps/in.void_small), thresholded on the atoms' potential energy (c_pe), keeps
// the atoms on the void's surface; the render equals that of a store converted from just those
// atoms; the culled view converges to its every-particle reference; streamed, the nodes without
// a kept atom are never read and the image is the in-memory one; picking skips what is left out;
// and the errors name the option and write nothing.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "render/scene.h"
#include "store/format.h"
#include "store/hash.h"
#include "store/store_reader.h"
#include "store/threshold.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

using ::testing::HasSubstr;
using testing::compare_exr;
using testing::ExrDifference;
namespace fs = std::filesystem;
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Threshold, ParsesBoundsOpenEndsAndInvert) {
  auto a = store::parse_threshold("-3.5:-2");
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_EQ(a->lo, -3.5);
  EXPECT_EQ(a->hi, -2.0);
  EXPECT_FALSE(a->invert);
  auto b = store::parse_threshold(" 0.1 : ,invert");
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_EQ(b->lo, 0.1);
  EXPECT_EQ(b->hi, kInf);
  EXPECT_TRUE(b->invert);
  auto c = store::parse_threshold(":+4e3");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->lo, -kInf);
  EXPECT_EQ(c->hi, 4000.0);
  EXPECT_EQ(*store::parse_threshold("2:2"), (store::Threshold{2.0, 2.0, false}));
  // The spec reads back as the same threshold.
  for (const char* spec : {"-3.5:-2", "0.1:,invert", ":4000", "1e-300:0.30000000000000004"}) {
    auto t = store::parse_threshold(spec);
    ASSERT_TRUE(t.ok()) << spec;
    EXPECT_EQ(*store::parse_threshold(store::threshold_spec(*t)), *t) << spec;
  }
  EXPECT_EQ(store::threshold_spec(*b), "0.1:,invert");
  for (const char* bad : {"", ":", " : ", "1", "1:2:3", "2:1", "a:1", "1:inf", "nan:1", "1:2,inverted", "1:2,", "1e999:", "+-5:", "--5:"})
    EXPECT_FALSE(store::parse_threshold(bad).ok()) << bad;
  EXPECT_THAT(store::parse_threshold("2:1").error().message, HasSubstr("LO 2 is greater than HI 1"));
  EXPECT_THAT(store::parse_threshold(":").error().message, HasSubstr("give LO, HI or both"));
}

TEST(Threshold, KeepsTheClosedIntervalOrItsComplement) {
  const store::Threshold t{-1.0, 2.0, false}, inv{-1.0, 2.0, true}, open{-kInf, 0.0, false};
  for (const double v : {-1.0, 0.0, 2.0}) EXPECT_TRUE(store::threshold_keeps(t, v)) << v;  // bounds included
  for (const double v : {std::nextafter(-1.0, -2.0), std::nextafter(2.0, 3.0), -1e300, 1e300})
    EXPECT_FALSE(store::threshold_keeps(t, v)) << v;
  for (const double v : {-1e300, -1.0, 0.0, 2.0, 3.0, 1e300})
    EXPECT_NE(store::threshold_keeps(t, v), store::threshold_keeps(inv, v)) << v;  // exactly the others
  EXPECT_TRUE(store::threshold_keeps(open, -1e300));
  EXPECT_FALSE(store::threshold_keeps(open, 1e-300));
  // The table: one entry per quantized value, the decoded value tested (the store's arithmetic).
  const std::vector<uint8_t> table = store::threshold_table(t, -3.0f, 5.0f);
  ASSERT_EQ(table.size(), size_t(store::kQuantMax) + 1);
  size_t kept = 0;
  for (uint32_t q = 0; q <= store::kQuantMax; ++q) {
    const double v = store::property_value(-3.0f, 5.0f, uint16_t(q));
    ASSERT_EQ(table[q] != 0, v >= -1.0 && v <= 2.0) << q;
    kept += table[q];
  }
  EXPECT_EQ(kept, size_t(std::floor(5.0 * 65535 / 8) - std::ceil(2.0 * 65535 / 8) + 1));
  // A property with one value (min == max): all or nothing.
  EXPECT_EQ(store::threshold_table(t, 1.0f, 1.0f), std::vector<uint8_t>(65536, 1));
  EXPECT_EQ(store::threshold_table(t, 4.0f, 4.0f), std::vector<uint8_t>(65536, 0));
}

TEST(Threshold, FilterKeepsParticlesByTheirPropertyMeshletByMeshlet) {
  store::NodeData in;
  in.meshlet_size = {3, 2};
  in.qpos.assign(15, 7);
  in.type_index = {0, 1, 0, 1, 1};
  in.property_q = {0, 40000, 65535, 10, 30000};
  const std::vector<uint8_t> table = store::threshold_table({0.5, kInf, false}, 0.0f, 1.0f);  // q >= 32768
  store::NodeData out;
  render::filter_particles(in, render::ParticleFilter{{}, {}, nullptr, nullptr, table}, out);
  EXPECT_EQ(out.meshlet_size, (std::vector<uint8_t>{2}));  // the second meshlet left empty: dropped
  EXPECT_EQ(out.property_q, (std::vector<uint16_t>{40000, 65535}));
  EXPECT_EQ(out.type_index, (std::vector<uint8_t>{1, 0}));
  // With the types too: type 1 left out as well.
  const std::vector<uint8_t> shown = {1, 0};
  render::filter_particles(in, render::ParticleFilter{shown, {}, nullptr, nullptr, table}, out);
  EXPECT_EQ(out.property_q, (std::vector<uint16_t>{65535}));
}

int run(const std::string& args) { return testing::run_mdstream(args); }
std::string last_stderr() { return testing::cli_stderr(); }

// The atoms of the last frame of LAMMPS' dump (id type x y z c_pe), as LAMMPS wrote them.
struct Atom {
  int type = 0;
  double x[3] = {0, 0, 0};
  double pe = 0;
};
std::vector<Atom> last_frame(const fs::path& dump) {
  std::ifstream in(dump);
  std::string line;
  std::vector<Atom> atoms;
  while (std::getline(in, line)) {
    if (line.rfind("ITEM: ATOMS", 0) == 0) {
      atoms.clear();
      continue;
    }
    std::istringstream ls(line);
    long long id = 0;
    Atom a;
    if (line.rfind("ITEM:", 0) != 0 && (ls >> id >> a.type >> a.x[0] >> a.x[1] >> a.x[2] >> a.pe)) atoms.push_back(a);
  }
  return atoms;
}

std::string slurp_text(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

double stats_particles(const fs::path& json) {
  return nlohmann::json::parse(std::ifstream(json)).at("particles").get<double>();
}
size_t xyz_count(const fs::path& xyz) {
  std::ifstream in(xyz);
  size_t n = 0;
  in >> n;
  return n;
}

class ThresholdCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    lammps_ = textest::cached_lammps_run("in.void_small");
    ASSERT_FALSE(lammps_.empty()) << "lmp failed on in.void_small";
    dir_ = fs::temp_directory_path() / ("mds_threshold_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    ASSERT_EQ(run("convert -q --frame last --property c_pe " + dump().string() + " -o " + store()), 0) << last_stderr();
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static fs::path dump() { return lammps_ / "void.lammpstrj"; }
  static std::string store() { return (dir_ / "v.mds").string(); }
  static fs::path lammps_, dir_;
};
fs::path ThresholdCli::lammps_, ThresholdCli::dir_;

// The void's surface: --threshold -6: keeps the atoms whose potential energy LAMMPS put above -6
// (every one of them, and no other: none lies within the store's quantization step of -6), and
// they lie on the void's surface. The render draws exactly them: the same count, and the same
// image as the store converted from just those atoms (`export --threshold`), in the same colours
// from the same camera; without the threshold the image differs.
TEST_F(ThresholdCli, KeepsTheVoidSurfaceAndDrawsWhatAStoreOfItDraws) {
  const std::vector<Atom> atoms = last_frame(dump());
  ASSERT_EQ(atoms.size(), 3317u);  // 4000 sites less the void
  double lo = 1e300, hi = -1e300;
  for (const Atom& a : atoms) lo = std::min(lo, a.pe), hi = std::max(hi, a.pe);
  const double step = (hi - lo) / store::kQuantMax;
  size_t kept = 0;
  const double lattice = std::cbrt(4.0 / 0.8442), centre = 5.0 * lattice, radius = 3.5 * lattice;
  for (const Atom& a : atoms) {
    ASSERT_GT(std::abs(a.pe + 6.0), 2 * step) << "an atom at the threshold: the count is not decided";
    if (a.pe < -6.0) continue;
    ++kept;
    const double d = std::hypot(a.x[0] - centre, a.x[1] - centre, a.x[2] - centre);
    EXPECT_GT(d, radius) << "a high-energy atom inside the void";
    EXPECT_LT(d, radius + 1.5) << "a high-energy atom away from the void's surface";
  }
  ASSERT_GT(kept, 100u);
  ASSERT_LT(kept, atoms.size() / 4);
  // export --threshold writes them; inverted, the others.
  ASSERT_EQ(run("export " + store() + " -o " + (dir_ / "kept.xyz").string() + " --threshold=-6:"), 0) << last_stderr();
  EXPECT_EQ(xyz_count(dir_ / "kept.xyz"), kept);
  ASSERT_EQ(run("export " + store() + " -o " + (dir_ / "rest.mmpld").string() + " --threshold=-6:,invert"), 0)
      << last_stderr();
  ASSERT_EQ(run("convert -q " + (dir_ / "rest.mmpld").string() + " -o " + (dir_ / "rest.mds").string() +
                " --json-report " + (dir_ / "rest.json").string()),
            0)
      << last_stderr();
  EXPECT_EQ(stats_particles(dir_ / "rest.json"), double(atoms.size() - kept));
  ASSERT_EQ(run("convert -q " + (dir_ / "kept.xyz").string() + " -o " + (dir_ / "kept.mds").string()), 0)
      << last_stderr();
  // The same colours by type: the exported XYZ names its types by their ids, "1" and "2".
  const std::string look = " --camera 30,-24,26,8.4,8.4,8.4 --no-cull --spp 4 --width 96 --height 72 "
                           "--background 0,0,0 --cell off --type-color 1=#e15759 --type-color 2=#4e79a7 --color-by type";
  ASSERT_EQ(run("render " + store() + " -o " + (dir_ / "t.exr").string() + " --threshold=-6: --stats " +
                (dir_ / "t.json").string() + look),
            0)
      << last_stderr();
  ASSERT_EQ(run("render " + (dir_ / "kept.mds").string() + " -o " + (dir_ / "k.exr").string() + " --stats " +
                (dir_ / "k.json").string() + look),
            0)
      << last_stderr();
  EXPECT_EQ(stats_particles(dir_ / "t.json"), double(kept));
  EXPECT_EQ(stats_particles(dir_ / "k.json"), double(kept));
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(dir_ / "t.json")).at("threshold"), "-6:");
  const ExrDifference d = compare_exr(dir_ / "t.exr", dir_ / "k.exr", 96, 72);
  EXPECT_GT(d.covered, size_t(96 * 72) / 20);
  EXPECT_LE(d.differing, size_t(96 * 72) / 200) << d.differing << " of " << d.covered << " covered pixels";
  ASSERT_EQ(run("render " + store() + " -o " + (dir_ / "w.exr").string() + look), 0) << last_stderr();
  EXPECT_GT(compare_exr(dir_ / "t.exr", dir_ / "w.exr", 96, 72).differing, size_t(96 * 72) / 20);
}

// Culled, the shell converges to its every-particle reference: the occluders, the boxes and the
// density volume are those of the kept atoms (the store's density counts the whole crystal).
TEST_F(ThresholdCli, CulledThresholdConvergesToItsReference) {
  const fs::path json = dir_ / "bench.json";
  ASSERT_EQ(run("bench " + store() + " --view 1 --width 64 --height 48 --threshold=-6: --spp-list 4 "
                "--reference-spp 4 --coverage exact --json " + json.string() + " > /dev/null"),
            0)
      << last_stderr();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  // Rows and reference draw the kept atoms only (LAMMPS' count above -6, as in the test above).
  size_t kept = 0;
  for (const Atom& a : last_frame(dump())) kept += a.pe >= -6.0;
  EXPECT_EQ(j.at("particles"), kept);
  size_t checked = 0;
  for (const auto& r : j.at("rows")) {
    if (r.at("mode").get<std::string>() != "culled") continue;
    ++checked;
    EXPECT_TRUE(r.at("converged").get<bool>());
    EXPECT_LE(r.at("differing_fraction").get<double>(), 0.01) << r.dump();
  }
  EXPECT_EQ(checked, 1u) << j.dump();
}

// A pixel whose ray meets the shell names a kept atom; a pixel that shows the crystal's bulk
// without the threshold names an atom of lower energy there.
TEST_F(ThresholdCli, PickSkipsWhatTheThresholdLeavesOut) {
  std::string picks;
  for (int x = 30; x <= 66; x += 6) picks += " --pick " + std::to_string(x) + ",36";
  const std::string base = "render " + store() + " -o " + (dir_ / "p.png").string() +
                           " --view 0 --width 96 --height 72 --spp 1 --no-cull" + picks;
  const fs::path with = dir_ / "with.txt", without = dir_ / "without.txt";
  ASSERT_EQ(run(base + " --threshold=-6: > " + with.string()), 0) << last_stderr();
  ASSERT_EQ(run(base + " > " + without.string()), 0) << last_stderr();
  std::ifstream a(with), b(without);
  std::string la, lb;
  size_t hits = 0, bulk = 0;
  while (std::getline(a, la) && std::getline(b, lb)) {
    const nlohmann::json ja = nlohmann::json::parse(la), jb = nlohmann::json::parse(lb);
    if (!jb.at("particle").is_null() && jb["particle"]["property"]["value"].get<double>() < -6.0) ++bulk;
    if (ja.at("particle").is_null()) continue;
    ++hits;
    EXPECT_GE(ja["particle"]["property"]["value"].get<double>(), -6.0) << la;
  }
  EXPECT_GT(hits, 0u);
  EXPECT_GT(bulk, 0u);
}

// Streamed (--gpu-budget): the cache tells from the nodes' property histograms which nodes hold
// no atom above -6 and never reads them; it reads and thins the others; the converged image is
// the in-memory one. Checked against the payloads themselves: the nodes left out are exactly
// those none of whose decoded values is kept, and the node log shows no read of any of them.
// export skips them too (a damaged payload there goes unnoticed).
// The pool (512 KiB) is below the store's pages (104 nodes of 50 atoms, a page each).
TEST_F(ThresholdCli, StreamedReadsNoNodeItLeavesOutAndMatchesInMemory) {
  const fs::path small = dir_ / "v50.mds";
  ASSERT_EQ(run("convert -q --frame last --property c_pe --node-size 50 " + dump().string() + " -o " + small.string()), 0)
      << last_stderr();
  auto reader = store::StoreReader::open(small);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  const store::FileHeader& h = (*reader)->header();
  ASSERT_TRUE(h.flags & store::kFlagPropertyHistogram);
  std::vector<bool> holds_kept;
  store::NodeData data;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < (*reader)->nodes().size(); ++i) {
    ASSERT_TRUE((*reader)->read_node(i, data, scratch).ok());
    bool any = false;
    for (uint16_t q : data.property_q) any = any || store::property_value(h.property_min, h.property_max, q) >= -6.0;
    holds_kept.push_back(any);
  }
  const size_t left_out = size_t(std::count(holds_kept.begin(), holds_kept.end(), false));
  ASSERT_GT(left_out, holds_kept.size() / 4);  // the bulk away from the void
  ASSERT_LT(left_out, holds_kept.size());
  const std::string look = " --spp 4 --width 160 --height 120 --background 0,0,0 --threshold=-6:";
  for (const char* view : {"0", "2"}) {
    SCOPED_TRACE(std::string("view ") + view);
    const fs::path mem = dir_ / "mem.exr", streamed = dir_ / "streamed.exr", stats = dir_ / "s.json", log = dir_ / "n.csv";
    ASSERT_EQ(run("render " + small.string() + " -o " + mem.string() + " --no-cull --view " + view + look), 0)
        << last_stderr();
    ASSERT_EQ(run("render " + small.string() + " -o " + streamed.string() + " --gpu-budget 512KiB --view " + view +
                  " --stats " + stats.string() + " --node-log " + log.string() + look),
              0)
        << last_stderr();
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(stats));
    EXPECT_TRUE(j.at("converged").get<bool>());
    EXPECT_FALSE(j.at("budget_exhausted").get<bool>());
    EXPECT_EQ(j.at("nodes_left_out").get<size_t>(), left_out);
    EXPECT_LT(j.at("bytes_read").get<uint64_t>(), j.at("store_payload_bytes").get<uint64_t>());
    EXPECT_EQ(j.at("threshold").get<std::string>(), "-6:");
    // Within the renderer's tolerance, not to the pixel: the culling classes follow the order the
    // reader threads deliver the nodes in, and a node classified occluded may hide a sphere's
    // last pixel (0 pixels differed when measured; test_series_cli's prior/cold images, 1).
    const ExrDifference d = compare_exr(mem, streamed, 160, 120);
    EXPECT_GT(d.covered, 500u);
    EXPECT_LE(d.differing, size_t(160 * 120) / 200) << d.differing << " of " << d.covered << " covered pixels";
    // Node log: node,particles,payload_bytes,class,visible,carried,requests,reads,...
    std::ifstream in(log);
    std::string line;
    std::getline(in, line);
    size_t rows = 0;
    while (std::getline(in, line)) {
      std::vector<std::string> f;
      std::stringstream ls(line);
      for (std::string x; std::getline(ls, x, ',');) f.push_back(x);
      ASSERT_GE(f.size(), 8u) << line;
      const size_t node = std::stoul(f[0]);
      ASSERT_LT(node, holds_kept.size());
      if (!holds_kept[node]) {
        EXPECT_EQ(f[7], "0") << "node " << node << " holds no kept atom but was read";
      }
      ++rows;
    }
    EXPECT_EQ(rows, holds_kept.size());
  }
  // stress --threshold along an orbit: the same nodes left out and never loaded; its report says
  // which threshold it ran with.
  {
    const fs::path sj = dir_ / "stress.json";
    ASSERT_EQ(run("stress " + small.string() + " --gpu-budget 512KiB --path orbit --frames 8 --width 96 --height 72 "
                  "--threshold=-6: -q --json " + sj.string()),
              0)
        << last_stderr();
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(sj));
    EXPECT_EQ(j.at("threshold").get<std::string>(), "-6:");
    EXPECT_TRUE(j.at("slices").empty());
    EXPECT_EQ(j.at("nodes_left_out").get<size_t>(), left_out);
    EXPECT_GE(j.at("nodes_never_loaded").get<size_t>(), left_out);
    EXPECT_GT(j.at("nodes_loaded").get<size_t>(), 0u);
    EXPECT_GT(j.at("hit_rate_over_belady").get<double>(), 0.0);
  }
  // export --threshold reads no node the histograms leave out either: with the payload of one
  // such node damaged, it still writes every kept atom, where export without it names the damage.
  const auto nodes = (*reader)->nodes();
  const size_t bad = size_t(std::find(holds_kept.begin(), holds_kept.end(), false) - holds_kept.begin());
  std::vector<uint8_t> b;
  {
    std::ifstream f(small, std::ios::binary);
    b.assign(std::istreambuf_iterator<char>(f), {});
  }
  {
    std::vector<uint8_t> damaged = b;
    damaged[size_t(nodes[bad].payload_offset) + 3] ^= 0x40;
    const fs::path p = dir_ / "damaged.mds";
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(damaged.data()), std::streamsize(damaged.size()));
    ASSERT_EQ(run("export " + p.string() + " -o " + (dir_ / "d.xyz").string() + " --threshold=-6:"), 0) << last_stderr();
    ASSERT_EQ(run("export " + small.string() + " -o " + (dir_ / "s.xyz").string() + " --threshold=-6:"), 0)
        << last_stderr();
    EXPECT_EQ(xyz_count(dir_ / "d.xyz"), xyz_count(dir_ / "s.xyz"));
    EXPECT_NE(run("export " + p.string() + " -o " + (dir_ / "all.xyz").string()), 0);
    EXPECT_THAT(last_stderr(), HasSubstr("node " + std::to_string(bad) + " payload at byte"));
  }
  // A store converted before the histograms (here: the section taken off, the flag cleared):
  // refused streamed, with what to do; in memory it renders.
  store::FileHeader old;
  std::memcpy(&old, b.data(), sizeof old);
  b.resize(size_t(old.property_histograms.offset));
  old.flags &= ~uint32_t(store::kFlagPropertyHistogram);
  old.property_histograms = {};
  old.header_hash = 0;
  old.header_hash = store::hash_bytes({reinterpret_cast<const uint8_t*>(&old), sizeof old});
  std::memcpy(b.data(), &old, sizeof old);
  const fs::path before = dir_ / "before.mds";
  std::ofstream(before, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
  const fs::path png = dir_ / "old.png";
  EXPECT_EQ(run("render " + before.string() + " -o " + png.string() + " --gpu-budget 512KiB" + look), 2);
  EXPECT_THAT(last_stderr(), HasSubstr("--threshold -6: with --gpu-budget: " + before.string() +
                                       " has no per-node property histograms"));
  EXPECT_FALSE(fs::exists(png));
  EXPECT_EQ(run("render " + before.string() + " -o " + png.string() + " --no-cull" + look), 0) << last_stderr();
}

// `info --histogram N` (choosing a threshold): the counts of the values `export` writes, binned
// by the rule the JSON's edges state, the same with nodes of 50 (with 3 bins, nodes whose values
// fall into one bin are counted from their property histograms) as with one node read whole.
TEST_F(ThresholdCli, InfoHistogramCountsTheExportedValues) {
  const fs::path small = dir_ / "h50.mds", json = dir_ / "h.json";
  ASSERT_EQ(run("convert -q --frame last --property c_pe --node-size 50 " + dump().string() + " -o " + small.string()), 0)
      << last_stderr();
  ASSERT_EQ(run("export " + small.string() + " -o " + (dir_ / "h.xyz").string()), 0) << last_stderr();
  auto reader = store::StoreReader::open(small);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  const double lo = (*reader)->header().property_min, hi = (*reader)->header().property_max;
  std::vector<double> values;
  {
    std::ifstream in(dir_ / "h.xyz");
    std::string line;
    std::getline(in, line);
    std::getline(in, line);
    while (std::getline(in, line)) {
      std::istringstream ls(line);
      std::string species;
      double x, y, z, v;
      ASSERT_TRUE(ls >> species >> x >> y >> z >> v) << line;
      values.push_back(v);
    }
  }
  for (const int bins : {12, 3}) {
    std::vector<uint64_t> want(size_t(bins), 0);
    for (const double v : values) ++want[size_t(std::clamp(std::floor((v - lo) / (hi - lo) * bins), 0.0, double(bins - 1)))];
    for (const std::string& path : {small.string(), store()}) {
      SCOPED_TRACE(path + " " + std::to_string(bins));
      ASSERT_EQ(run("info " + path + " --json --histogram " + std::to_string(bins) + " > " + json.string()), 0)
          << last_stderr();
      const nlohmann::json j = nlohmann::json::parse(std::ifstream(json)).at("property_histogram");
      EXPECT_EQ(j.at("name").get<std::string>(), "c_pe");
      EXPECT_EQ(j.at("counts").get<std::vector<uint64_t>>(), want);
      const auto edges = j.at("edges").get<std::vector<double>>();
      ASSERT_EQ(edges.size(), size_t(bins + 1));
      EXPECT_EQ(edges.front(), lo);
      EXPECT_EQ(edges.back(), hi);
      if (path == small.string() && bins == 3) {
        EXPECT_LT(j.at("nodes_read").get<uint64_t>(), (*reader)->nodes().size());
      }
    }
  }
  // The text form and the errors.
  ASSERT_EQ(run("info " + small.string() + " --histogram 4 > " + (dir_ / "h.txt").string()), 0) << last_stderr();
  EXPECT_THAT(slurp_text(dir_ / "h.txt"), HasSubstr("histogram        c_pe, 4 bins ("));
  EXPECT_EQ(run("info " + small.string() + " --histogram 0"), 2);
  const fs::path plain = dir_ / "hplain.mds";
  ASSERT_EQ(run("convert -q --frame last " + dump().string() + " -o " + plain.string()), 0) << last_stderr();
  EXPECT_NE(run("info " + plain.string() + " --histogram 4"), 0);
  EXPECT_THAT(last_stderr(), HasSubstr("--histogram: " + plain.string() + ": the store has no per-particle property"));
}

// A store without a property, a threshold that keeps nothing (in memory and streamed), a malformed spec:
// usage errors naming the option, no output.
TEST_F(ThresholdCli, ErrorsNameTheOptionAndWriteNothing) {
  const fs::path plain = dir_ / "plain.mds", png = dir_ / "bad.png", xyz = dir_ / "bad.xyz";
  ASSERT_EQ(run("convert -q --frame last " + dump().string() + " -o " + plain.string()), 0) << last_stderr();
  EXPECT_EQ(run("render " + plain.string() + " -o " + png.string() + " --threshold=-6:"), 2);
  EXPECT_THAT(last_stderr(), HasSubstr("--threshold -6:: " + plain.string() + " has no per-particle property"));
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --threshold 100:"), 2);
  EXPECT_THAT(last_stderr(), HasSubstr(store() + ": --threshold 100: leaves no particle of the store (its property 'c_pe'"));
  // Streamed, the cache finds it from the nodes' property histograms, before any frame.
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --threshold 100: --gpu-budget 1MiB"), 2);
  EXPECT_THAT(last_stderr(), HasSubstr(store() + ": --threshold 100: leaves no particle of the store"));
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --threshold=-6:x"), 2);
  EXPECT_THAT(last_stderr(), HasSubstr("--threshold '-6:x': HI 'x' is not a finite number"));
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --threshold=-6: --visible-reference"), 2);
  EXPECT_THAT(last_stderr(), HasSubstr("not with --hide-type, --type-radius, --slice or --threshold"));
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --threshold=-6: --node-log " + (dir_ / "n.csv").string()), 2);
  EXPECT_THAT(last_stderr(), HasSubstr("--node-log lists the store's nodes: in memory not with --hide-type, --slice or --threshold"));
  EXPECT_FALSE(fs::exists(png));
  // A series with a frame that has no property: refused before any frame is written.
  const fs::path series = dir_ / "mixed.series";
  std::ofstream(series) << R"({"file-series-version": "1.0", "files": [{"name": "v.mds", "time": 0}, )"
                        << R"({"name": "plain.mds", "time": 1}]})";
  EXPECT_EQ(run("render " + series.string() + " -o " + (dir_ / "f_%d.png").string() + " --threshold=-6: --spp 1 "
                "--width 32 --height 24"),
            2);
  EXPECT_THAT(last_stderr(), HasSubstr("--threshold: not every picked frame of " + series.string() +
                                       " has a per-particle property"));
  EXPECT_FALSE(fs::exists(dir_ / "f_0.png"));
  EXPECT_EQ(run("export " + plain.string() + " -o " + xyz.string() + " --threshold=-6:"), 2);
  EXPECT_THAT(last_stderr(), HasSubstr("has no per-particle property"));
  EXPECT_EQ(run("export " + store() + " -o " + xyz.string() + " --threshold 100:"), 2);
  EXPECT_THAT(last_stderr(), HasSubstr(store() + ": --threshold 100: leaves no particle of the store"));
  EXPECT_EQ(run("export " + store() + " -o " + xyz.string() + " --threshold=-6: --slice 1,0,0,-100"), 2);
  EXPECT_THAT(last_stderr(), HasSubstr(": --slice with --threshold -6: leaves no particle"));
  EXPECT_FALSE(fs::exists(xyz));
}

}  // namespace
}  // namespace mds
