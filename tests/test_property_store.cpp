// The per-particle property end to end: the payload codec with property_q, the header's
// property fields treated as hostile, `convert --property` on real LAMMPS output (round trip
// through `export` within half a quantization step, `info`), and `render --color-by property`
// against `--color-by x` on a dump whose property is each particle's x (in memory and
// streamed), plus the usage errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "store/format.h"
#include "store/hash.h"
#include "store/payload_codec.h"
#include "store/store_reader.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::run_mdstream;

// A node of n particles in meshlets of up to 16 with random positions, types, radii, property.
struct RandomNode {
  std::vector<uint16_t> qpos, radius_q, property_q;
  std::vector<uint8_t> type_index, meshlet_size;
  RandomNode(size_t n, bool radius, bool property, uint32_t seed) {
    std::mt19937 rng(seed);
    for (size_t i = 0; i < 3 * n; ++i) qpos.push_back(uint16_t(rng()));
    for (size_t i = 0; i < n; ++i) {
      type_index.push_back(uint8_t(rng() % 3));
      if (radius) radius_q.push_back(uint16_t(rng()));
      if (property) property_q.push_back(uint16_t(rng()));
    }
    for (size_t done = 0; done < n;) {
      const size_t k = std::min<size_t>(1 + rng() % 16, n - done);
      meshlet_size.push_back(uint8_t(k));
      done += k;
    }
  }
  store::NodeInput input() const {
    store::NodeInput in{};
    in.qpos = qpos;
    in.type_index = type_index;
    in.radius_q = radius_q;
    in.property_q = property_q;
    in.meshlet_size = meshlet_size;
    return in;
  }
};

TEST(StoreProperty, PayloadRoundTripsBehindTheRadii) {
  for (const bool radius : {false, true}) {
    for (const bool property : {false, true}) {
      SCOPED_TRACE(fmt::format("radius {} property {}", radius, property));
      const RandomNode node(300, radius, property, 11u + 2u * radius + property);
      std::vector<uint8_t> raw;
      store::encode_payload(node.input(), raw);
      const uint32_t flags =
          (radius ? store::kFlagPerParticleRadius : 0u) | (property ? store::kFlagProperty : 0u);
      EXPECT_GE(raw.size(), store::node_payload_fixed_bytes(300, node.meshlet_size.size(), flags));
      const store::PayloadLimits lim{300, uint32_t(node.meshlet_size.size()), flags, 3, 16};
      store::NodeData out;
      ASSERT_TRUE(store::decode_payload_raw(raw, lim, out).ok());
      EXPECT_EQ(out.qpos, node.qpos);
      EXPECT_EQ(out.type_index, node.type_index);
      EXPECT_EQ(out.radius_q, node.radius_q);
      EXPECT_EQ(out.property_q, node.property_q);
      // Decoded with the other flag set, the sizes no longer add up: an error, not a misread.
      const store::PayloadLimits wrong{300, lim.meshlet_count, flags ^ store::kFlagProperty, 3, 16};
      EXPECT_FALSE(store::decode_payload_raw(raw, wrong, out).ok());
    }
  }
}

// Real LAMMPS output (tests/data/lammps/in.property_small, last frame) converted with
// --property c_pe; the suite's stores are shared.
class PropertyConvert : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const fs::path run = textest::cached_lammps_run("in.property_small");
    ASSERT_FALSE(run.empty()) << "lmp failed on in.property_small";
    dump_ = run / "dump.property.lammpstrj";
    dir_ = fs::temp_directory_path() / ("mds_property_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    store_ = dir_ / "pe.mds";
    ASSERT_EQ(run_mdstream(fmt::format("convert {} --frame last --property c_pe --node-size 100 -q -o {}",
                                       dump_.string(), store_.string())),
              0)
        << cli_stderr();
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::vector<uint8_t> bytes(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), {}};
  }
  static inline fs::path dump_, dir_, store_;
};

TEST_F(PropertyConvert, ExportGivesEveryValueWithinHalfAStep) {
  // The dump's last frame: id -> c_pe (the columns are id type x y z c_pe vx).
  std::ifstream f(dump_);
  std::vector<std::string> lines;
  for (std::string l; std::getline(f, l);) lines.push_back(l);
  size_t last_atoms = 0;
  for (size_t i = 0; i < lines.size(); ++i)
    if (lines[i].rfind("ITEM: ATOMS", 0) == 0) last_atoms = i;
  std::vector<double> pe;
  for (size_t i = last_atoms + 1; i < lines.size(); ++i) {
    std::istringstream s(lines[i]);
    double v[7];
    for (double& x : v) s >> x;
    pe.push_back(v[5]);
  }
  ASSERT_EQ(pe.size(), 864u);
  const double lo = *std::min_element(pe.begin(), pe.end()), hi = *std::max_element(pe.begin(), pe.end());

  const fs::path info = dir_ / "info.json";
  ASSERT_EQ(run_mdstream("info " + store_.string() + " --json > " + info.string()), 0) << cli_stderr();
  std::ifstream fi(info);
  const nlohmann::json j = nlohmann::json::parse(fi);
  EXPECT_EQ(j["property"]["name"], "c_pe");
  EXPECT_EQ(j["property"]["min"].get<double>(), double(float(lo)));
  EXPECT_EQ(j["property"]["max"].get<double>(), double(float(hi)));

  // export: extended XYZ with the property as a column; positions identify the particles.
  const fs::path xyz = dir_ / "pe.xyz";
  ASSERT_EQ(run_mdstream("export " + store_.string() + " -o " + xyz.string()), 0) << cli_stderr();
  std::ifstream fx(xyz);
  std::string count, header;
  std::getline(fx, count);
  std::getline(fx, header);
  EXPECT_THAT(header, HasSubstr("Properties=species:S:1:pos:R:3:c_pe:R:1"));
  std::vector<double> exported;
  for (std::string l; std::getline(fx, l);) {
    std::istringstream s(l);
    std::string sp;
    double x, y, z, v;
    s >> sp >> x >> y >> z >> v;
    exported.push_back(v);
  }
  ASSERT_EQ(exported.size(), pe.size());
  // The same multiset of values up to half a step: compare sorted.
  std::sort(pe.begin(), pe.end());
  std::sort(exported.begin(), exported.end());
  const double half_step = (double(float(hi)) - double(float(lo))) / 65535.0 / 2.0;
  double worst = 0.0;
  for (size_t i = 0; i < pe.size(); ++i) worst = std::max(worst, std::abs(exported[i] - pe[i]));
  EXPECT_LE(worst, half_step * 1.001 + 1e-6 * std::abs(lo)) << "half step " << half_step;
  EXPECT_GT(worst, 0.0);  // quantized, not copied

  // Converting the export back keeps the property (the XYZ reader's R:1 column).
  const fs::path again = dir_ / "again.mds";
  ASSERT_EQ(run_mdstream("convert " + xyz.string() + " --property c_pe -q -o " + again.string()), 0) << cli_stderr();
}

TEST_F(PropertyConvert, HeaderFieldsAreCheckedOnOpen) {
  const std::vector<uint8_t> good = bytes(store_);
  ASSERT_GE(good.size(), store::kHeaderBytes);
  auto with = [&](auto edit) {
    std::vector<uint8_t> b = good;
    store::FileHeader h;
    std::memcpy(&h, b.data(), sizeof h);
    edit(h);
    h.header_hash = 0;
    h.header_hash = store::hash_bytes({reinterpret_cast<const uint8_t*>(&h), sizeof h});
    std::memcpy(b.data(), &h, sizeof h);
    const fs::path p = dir_ / "edited.mds";
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
    auto r = store::StoreReader::open(p);
    return r.ok() ? std::string("(opened)") : r.error().message;
  };
  EXPECT_EQ(with([](store::FileHeader&) {}), "(opened)");
  EXPECT_THAT(with([](store::FileHeader& h) { std::memset(h.property_name, 0, sizeof h.property_name); }),
              HasSubstr("field property_name at byte 360: empty"));
  EXPECT_THAT(with([](store::FileHeader& h) { std::memset(h.property_name, 'a', sizeof h.property_name); }),
              HasSubstr("not NUL-terminated"));
  EXPECT_THAT(with([](store::FileHeader& h) { h.property_name[10] = 'x'; }), HasSubstr("not zero after the name's NUL"));
  EXPECT_THAT(with([](store::FileHeader& h) { std::swap(h.property_min, h.property_max); }),
              HasSubstr("field property_min/property_max at byte 408"));
  EXPECT_THAT(with([](store::FileHeader& h) { h.property_max = NAN; }), HasSubstr("property_min/property_max"));
  // Without the flag the payloads are shorter than the directory says, and the fields must be zero.
  EXPECT_THAT(with([](store::FileHeader& h) { h.flags &= ~uint32_t(store::kFlagProperty); }),
              HasSubstr("field property_name at byte 360: not zero without the property flag"));
  EXPECT_THAT(with([](store::FileHeader& h) {
                h.flags &= ~uint32_t(store::kFlagProperty);
                std::memset(h.property_name, 0, sizeof h.property_name);
                h.property_min = h.property_max = 0.0f;
              }),
              HasSubstr("field flags at byte 16: property histograms without the property flag"));
  EXPECT_THAT(with([](store::FileHeader& h) {
                h.flags &= ~uint32_t(store::kFlagProperty | store::kFlagPropertyHistogram);
                std::memset(h.property_name, 0, sizeof h.property_name);
                h.property_min = h.property_max = 0.0f;
              }),
              HasSubstr("field property_histograms at byte 448: not zero without the property histogram flag"));
  EXPECT_THAT(with([](store::FileHeader& h) {
                h.flags &= ~uint32_t(store::kFlagProperty | store::kFlagPropertyHistogram);
                std::memset(h.property_name, 0, sizeof h.property_name);
                h.property_min = h.property_max = 0.0f;
                h.property_histograms = {};
              }),
              HasSubstr("bytes after the last section"));
}

TEST_F(PropertyConvert, UsageErrors) {
  const fs::path out = dir_ / "bad.mds";
  EXPECT_NE(run_mdstream("convert " + dump_.string() + " --property " + std::string(48, 'p') + " -q -o " + out.string()),
            0);
  EXPECT_THAT(cli_stderr(), HasSubstr("--property"));
  EXPECT_NE(run_mdstream("convert " + dump_.string() + " --property nothing -q -o " + out.string()), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("no column 'nothing'"));
  EXPECT_FALSE(fs::exists(out));
  const fs::path plain = dir_ / "plain.mds";
  ASSERT_EQ(run_mdstream("convert " + dump_.string() + " -q -o " + plain.string()), 0) << cli_stderr();
  EXPECT_NE(run_mdstream("render " + plain.string() + " --color-by property --width 8 --height 8 -o " +
                         (dir_ / "p.png").string()),
            0);
  EXPECT_THAT(cli_stderr(), HasSubstr("no per-particle property"));
  EXPECT_NE(run_mdstream("render " + plain.string() + " --color-by c_pe -o " + (dir_ / "p.png").string()), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("--color-by 'c_pe'"));
  EXPECT_THAT(cli_stderr(), HasSubstr("has no property"));
  EXPECT_NE(run_mdstream("render " + store_.string() + " --color-by c_ke -o " + (dir_ / "p.png").string()), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("the name of " + store_.string() + "'s property, c_pe"));
  EXPECT_FALSE(fs::exists(dir_ / "p.png"));
}

// A LAMMPS dump of n particles uniform in [0, extent]^3, types 1..types in turn, with one more
// column `name` = f(x, y, z) (%.9g).
void write_property_dump(const fs::path& path, int n, uint32_t seed, double extent, int types, const std::string& name,
                         double (*f)(double, double, double)) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, extent);
  std::string text = fmt::format(
      "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS pp pp pp\n0 {}\n0 {}\n0 {}\n"
      "ITEM: ATOMS id type x y z {}\n",
      n, extent, extent, extent, name);
  for (int i = 0; i < n; ++i) {
    const double x = u(rng), y = u(rng), z = u(rng);
    text += fmt::format("{} {} {:.9g} {:.9g} {:.9g} {:.9g}\n", i + 1, 1 + i % types, x, y, z, f(x, y, z));
  }
  textest::write_text(path, text);
}

// Out of core (a memory budget far below the input: spilled records, several bins), each
// particle keeps its own value: a dump whose property is f(x, y, z) = x + 2y - z exports values
// within half a property step (plus what the positions' own quantization moves f) of f at the
// exported positions. Fails when the records' property is lost or mixed up between particles.
TEST(PropertyOutOfCore, EachParticleKeepsItsValueThroughSpillAndBins) {
  const fs::path dir = fs::temp_directory_path() / ("mds_property_ooc_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const int n = 120000;
  write_property_dump(dir / "f.lammpstrj", n, 9, 50.0, 3, "f", [](double x, double y, double z) { return x + 2 * y - z; });
  const fs::path store = dir / "f.mds", report = dir / "r.json", xyz = dir / "f.xyz";
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --property f --memory-budget 2MiB --node-size 1000 --density-res 1000 "
                                     "-q -o {} --json-report {}",
                                     (dir / "f.lammpstrj").string(), store.string(), report.string())),
            0)
      << cli_stderr();
  std::ifstream fr(report);
  const nlohmann::json j = nlohmann::json::parse(fr);
  EXPECT_TRUE(j["spilled"].get<bool>());
  EXPECT_GT(j["bins"].get<uint64_t>(), 1u);
  const double pmin = j["property"]["min"].get<double>(), pmax = j["property"]["max"].get<double>();
  const double pos_err = j["max_quantization_error"].get<double>();
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + xyz.string()), 0) << cli_stderr();
  std::ifstream fx(xyz);
  std::string line;
  std::getline(fx, line);
  std::getline(fx, line);
  const double bound = (pmax - pmin) / 65535.0 / 2.0 * 1.001 + 4.0 * pos_err + 1e-5;
  double worst = 0.0;
  size_t count = 0;
  while (std::getline(fx, line)) {
    std::istringstream s(line);
    std::string sp;
    double x, y, z, v;
    s >> sp >> x >> y >> z >> v;
    worst = std::max(worst, std::abs(v - (x + 2 * y - z)));
    ++count;
  }
  EXPECT_EQ(count, size_t(n));
  EXPECT_LE(worst, bound);
  fs::remove_all(dir);
}

// A block of particles whose property column is each particle's x: colouring by the property
// over a range must give the image of colouring by x over the same range (the property's 16
// bits cost at most 1 / 65535 of the range in t), in memory and streamed through a pool smaller
// than the store. Fails when the colour key's bits, the map's scale or offset, or the pool's
// property copies are wrong.
TEST(PropertyRender, PropertyEqualToXColoursLikeX) {
  const fs::path dir = fs::temp_directory_path() / ("mds_property_render_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  write_property_dump(dir / "px.lammpstrj", 6000, 5, 20.0, 2, "px", [](double x, double, double) { return x; });
  const std::string store = (dir / "px.mds").string();
  ASSERT_EQ(run_mdstream("convert " + (dir / "px.lammpstrj").string() + " --property px --node-size 500 -q -o " + store),
            0)
      << cli_stderr();
  auto render = [&](const std::string& name, const std::string& args) {
    const fs::path exr = dir / (name + ".exr");
    EXPECT_EQ(run_mdstream("render " + store + " --width 96 --height 72 --spp 2 --no-cull --view 0 -o " + exr.string() +
                           " " + args),
              0)
        << args << ": " << cli_stderr();
    return testing::load_exr(exr);
  };
  const std::vector<float> by_x = render("x", "--color-by x --color-range 2:17");
  for (const char* where : {"", "--gpu-budget 96KiB"}) {
    SCOPED_TRACE(where);
    const std::vector<float> by_p = render("p", std::string("--color-by property --color-range 2:17 ") + where);
    ASSERT_EQ(by_p.size(), by_x.size());
    double worst = 0.0;
    size_t covered = 0;
    for (size_t i = 0; i < by_x.size(); ++i) {
      worst = std::max(worst, double(std::abs(by_p[i] - by_x[i])));
      covered += (i % 4 == 3 && by_x[i] > 0.5f);
    }
    EXPECT_GT(covered, by_x.size() / 16);
    EXPECT_LT(worst, 2e-3);
  }
  // The property by its name is the same choice.
  const std::vector<float> by_name = render("n", "--color-by px --color-range 2:17");
  const std::vector<float> by_kw = render("k", "--color-by property --color-range 2:17");
  EXPECT_EQ(by_name, by_kw);
  // The type colours differ from that: the comparison can fail.
  const std::vector<float> typed = render("t", "");
  double diff = 0.0;
  for (size_t i = 0; i < typed.size(); ++i) diff = std::max(diff, double(std::abs(typed[i] - by_x[i])));
  EXPECT_GT(diff, 0.1);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mds
