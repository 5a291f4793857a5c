// Per-particle colours end to end (`convert --color`, store kFlagColor, `render --color-by
// color|auto`): the MMPLD reader on every colour type of every vertex type and version
// (tests/tools/write_mmpld.py computes the expected RGBA8 on its own), extended XYZ's
// color:R:3, the errors of inputs without colours, the payload codec, convert -> export in
// memory and out of core (each particle keeps its own colour), and rendering: a store whose
// colours are its types' colours renders like --color-by type with those colours, in memory
// and streamed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "binreader_test_util.h"
#include "cli_test_util.h"
#include "readers/mmpld_reader.h"
#include "readers/reader_factories.h"
#include "store/format.h"
#include "store/payload_codec.h"

namespace mds {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::run_mdstream;
using testing::TempDir;

// Every colour type but the intensities (NONE, UINT8_RGB, UINT8_RGBA, FLOAT_RGB, FLOAT_RGBA,
// USHORT_RGBA), and FLOAT_RGB(A) once more with channels in [-0.5, 1.5) (clamped).
json colour_spec(int version, int vertex, int seed) {
  json lists = json::array();
  for (int c : {0, 1, 2, 4, 5, 6})
    lists.push_back({{"vertex", vertex}, {"colour", c}, {"count", 6 + c}, {"radius", 0.5}});
  for (int c : {4, 5})
    lists.push_back({{"vertex", vertex}, {"colour", c}, {"count", 40}, {"radius", 0.5}, {"colour_range", {-0.5, 1.5}}});
  lists.push_back({{"vertex", 0}, {"colour", 1}, {"count", 9}});  // no positions: no particles
  return {{"version", version}, {"seed", seed}, {"frames", json::array({{{"lists", lists}}})}};
}

TEST(ColorReaders, MmpldEveryColourTypeOfEveryVertexTypeAndVersion) {
  TempDir dir;
  std::vector<std::string> args{testing::source_path("tests/tools/write_mmpld.py")};
  std::vector<json> specs;
  for (int version = 100; version <= 103; ++version)
    for (int vertex = 1; vertex <= 4; ++vertex) {
      const size_t i = specs.size();
      specs.push_back(colour_spec(version, vertex, 100 * version + vertex));
      testing::write_text(dir / fmt::format("s{}.json", i), specs.back().dump());
      args.insert(args.end(), {(dir / fmt::format("s{}.json", i)).string(), (dir / fmt::format("f{}.mmpld", i)).string(),
                               (dir / fmt::format("e{}.json", i)).string()});
    }
  ASSERT_EQ(testing::run_python(args), 0);
  for (size_t i = 0; i < specs.size(); ++i) {
    SCOPED_TRACE(specs[i].dump());
    std::ifstream ef(dir / fmt::format("e{}.json", i));
    const json exp = json::parse(ef)["frames"][0]["color"];
    ASSERT_EQ(exp.size(), 6u + 7 + 8 + 10 + 11 + 12 + 80);
    ReaderOptions o;
    o.color = true;
    auto r = open_reader(dir / fmt::format("f{}.mmpld", i), o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE((*r)->info().has_color);
    auto all = testing::read_all(**r, 7);  // batches cross list boundaries
    ASSERT_TRUE(all.ok()) << all.error().message;
    ASSERT_EQ(all->color.size(), exp.size());
    size_t clamped = 0;
    for (size_t k = 0; k < exp.size(); ++k) {
      ASSERT_EQ(all->color[k], exp[k].get<uint32_t>()) << "particle " << k;
      clamped += (all->color[k] & 0xffu) == 0 || (all->color[k] & 0xffu) == 255;
    }
    EXPECT_GT(clamped, 10u);  // the [-0.5, 1.5) lists reach both ends
  }
  // Without --color nothing is kept.
  auto plain = open_reader(dir / "f0.mmpld", {});
  ASSERT_TRUE(plain.ok());
  auto none = testing::read_all(**plain, 100);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->color.empty());
}

TEST(ColorReaders, MmpldIntensityAndNonFiniteChannelsAreErrors) {
  TempDir dir;
  const json spec = {{"version", 102},
                     {"seed", 5},
                     {"frames", {{{"lists", {{{"vertex", 1}, {"colour", 1}, {"count", 5}, {"radius", 0.5}},
                                             {{"vertex", 1}, {"colour", 3}, {"count", 5}, {"radius", 0.5}}}}}}}};
  testing::write_text(dir / "s.json", spec.dump());
  ASSERT_EQ(testing::run_python({testing::source_path("tests/tools/write_mmpld.py"), (dir / "s.json").string(),
                                 (dir / "i.mmpld").string(), (dir / "e.json").string()}),
            0);
  ReaderOptions o;
  o.color = true;
  auto r = open_reader(dir / "i.mmpld", o);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr((dir / "i.mmpld").string() + ": byte offset"));
  EXPECT_THAT(r.error().message, HasSubstr("list 1: colour type FLOAT_I is an intensity, not a colour"));

  // A FLOAT_RGB list whose third particle's green channel is NaN: the byte offset of that channel.
  const json rgb = {{"version", 100},
                    {"seed", 6},
                    {"frames", {{{"lists", {{{"vertex", 1}, {"colour", 4}, {"count", 4}, {"radius", 0.5}}}}}}}};
  testing::write_text(dir / "r.json", rgb.dump());
  ASSERT_EQ(testing::run_python({testing::source_path("tests/tools/write_mmpld.py"), (dir / "r.json").string(),
                                 (dir / "r.mmpld").string(), (dir / "re.json").string()}),
            0);
  auto m = MmpldReader::open(dir / "r.mmpld", o);
  ASSERT_TRUE(m.ok()) << m.error().message;
  const uint64_t green = dynamic_cast<MmpldReader&>(**m).lists()[0].data_offset + 2 * 24 + 12 + 4;
  std::vector<char> bytes = testing::read_bytes(dir / "r.mmpld");
  const float nan = std::nanf("");
  std::memcpy(bytes.data() + green, &nan, 4);
  testing::write_bytes(dir / "r.mmpld", bytes.data(), bytes.size());
  auto bad = open_reader(dir / "r.mmpld", o);
  ASSERT_TRUE(bad.ok());
  auto all = testing::read_all(**bad, 100);
  ASSERT_FALSE(all.ok());
  EXPECT_THAT(all.error().message, HasSubstr(fmt::format("byte offset {}: list 0 particle 2: non-finite colour", green)));
}

// Extended XYZ: n particles on distinct integer grid points with random 8-bit colours written
// as channels in [0, 1] (%.6f), species A/B in turn, with `charge` a property column charge = x
// + 2y - z before the colour; returns position -> RGBA8.
std::map<std::tuple<int, int, int>, uint32_t> write_color_xyz(const fs::path& path, int n, uint32_t seed,
                                                              bool charge = false) {
  std::mt19937 rng(seed);
  std::map<std::tuple<int, int, int>, uint32_t> colors;
  std::string text = fmt::format("{}\nProperties=species:S:1:pos:R:3{}:Color:R:3 Time=0\n", n, charge ? ":charge:R:1" : "");
  const int side = int(std::ceil(std::cbrt(double(n)))) + 1;
  while (int(colors.size()) < n) {
    const std::tuple<int, int, int> p{int(rng() % side), int(rng() % side), int(rng() % side)};
    if (colors.count(p)) continue;
    const uint32_t r = rng() % 256, g = rng() % 256, b = rng() % 256;
    colors[p] = pack_rgba8(r, g, b);
    const auto [x, y, z] = p;
    text += fmt::format("{} {} {} {}{} {:.6f} {:.6f} {:.6f}\n", colors.size() % 2 ? "A" : "B", x, y, z,
                        charge ? fmt::format(" {}", x + 2 * y - z) : "", r / 255.0, g / 255.0, b / 255.0);
  }
  testing::write_text(path, text);
  return colors;
}

TEST(ColorReaders, ExtendedXyzColorColumnsAndErrors) {
  TempDir dir;
  const auto colors = write_color_xyz(dir / "c.xyz", 500, 3);
  ReaderOptions o;
  o.color = true;
  auto r = open_reader(dir / "c.xyz", o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto all = testing::read_all(**r, 64);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->color.size(), 500u);
  for (size_t k = 0; k < 500; ++k)
    ASSERT_EQ(all->color[k], colors.at({int(all->x[k]), int(all->y[k]), int(all->z[k])})) << k;

  auto error_of = [&](const std::string& name, const std::string& text) {
    testing::write_text(dir / name, text);
    auto opened = open_reader(dir / name, o);
    if (!opened.ok()) return opened.error().message;
    auto read = testing::read_all(**opened, 64);
    return read.ok() ? std::string("(read)") : read.error().message;
  };
  EXPECT_THAT(error_of("none.xyz", "1\nProperties=species:S:1:pos:R:3\nA 0 0 0\n"),
              HasSubstr("none.xyz:2: Properties has no color:R:3 (--color)"));
  EXPECT_THAT(error_of("shape.xyz", "1\nProperties=species:S:1:pos:R:3:color:R:1\nA 0 0 0 1\n"),
              HasSubstr("shape.xyz:2: Properties: 'color' is R:1; --color needs R:3"));
  EXPECT_THAT(error_of("plain.xyz", "1\ncomment\nA 0 0 0\n"), HasSubstr("plain.xyz:2: a plain XYZ frame has no named"));
  EXPECT_THAT(error_of("nan.xyz", "2\nProperties=species:S:1:pos:R:3:color:R:3\nA 0 0 0 1 1 1\nA 1 0 0 1 nan 1\n"),
              HasSubstr("nan.xyz:4: bad colour channel (green) 'nan'"));
  // Other formats have no colours: named at open.
  testing::write_text(dir / "d.lammpstrj",
                      "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS pp pp pp\n0 1\n0 1\n0 1\n"
                      "ITEM: ATOMS id type x y z\n1 1 0.5 0.5 0.5\n");
  auto lammps = open_reader(dir / "d.lammpstrj", o);
  ASSERT_FALSE(lammps.ok());
  EXPECT_THAT(lammps.error().message, HasSubstr("d.lammpstrj: lammps input has no per-particle colours"));
}

TEST(ColorStore, PayloadRoundTripsBehindTheOtherColumns) {
  std::mt19937 rng(4);
  const size_t n = 300;
  std::vector<uint16_t> qpos(3 * n), radius_q(n), property_q(n);
  std::vector<uint8_t> type_index(n), sizes;
  std::vector<uint32_t> color(n);
  for (auto& q : qpos) q = uint16_t(rng());
  for (size_t i = 0; i < n; ++i) {
    type_index[i] = uint8_t(rng() % 3);
    radius_q[i] = uint16_t(rng());
    property_q[i] = uint16_t(rng());
    color[i] = uint32_t(rng());
  }
  for (size_t done = 0; done < n;) {
    const size_t k = std::min<size_t>(1 + rng() % 16, n - done);
    sizes.push_back(uint8_t(k));
    done += k;
  }
  for (const uint32_t others : {0u, uint32_t(store::kFlagPerParticleRadius | store::kFlagProperty)}) {
    SCOPED_TRACE(others);
    store::NodeInput in{};
    in.qpos = qpos;
    in.type_index = type_index;
    if (others) {
      in.radius_q = radius_q;
      in.property_q = property_q;
    }
    in.color = color;
    in.meshlet_size = sizes;
    std::vector<uint8_t> raw;
    store::encode_payload(in, raw);
    const uint32_t flags = others | store::kFlagColor;
    EXPECT_GE(raw.size(), store::node_payload_fixed_bytes(n, sizes.size(), flags));
    EXPECT_EQ(store::node_payload_fixed_bytes(n, sizes.size(), flags) -
                  store::node_payload_fixed_bytes(n, sizes.size(), others),
              4 * n);
    store::NodeData out;
    ASSERT_TRUE(store::decode_payload_raw(raw, {uint32_t(n), uint32_t(sizes.size()), flags, 3, 16}, out).ok());
    EXPECT_EQ(out.color, color);
    EXPECT_EQ(out.qpos, qpos);
    EXPECT_EQ(out.type_index, type_index);
    if (others) {
      EXPECT_EQ(out.property_q, property_q);
    }
    // Read without the flag, the sizes no longer add up: an error, not a misread.
    EXPECT_FALSE(store::decode_payload_raw(raw, {uint32_t(n), uint32_t(sizes.size()), others, 3, 16}, out).ok());
  }
}

// The colour columns (the last three) of an export's particle lines, sorted.
std::vector<std::string> exported_colors(const fs::path& xyz) {
  std::ifstream f(xyz);
  std::vector<std::string> out;
  std::string line;
  for (int skip = 0; skip < 2; ++skip) std::getline(f, line);
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::vector<std::string> tokens;
    for (std::string t; s >> t;) tokens.push_back(t);
    if (tokens.size() >= 3) out.push_back(tokens[tokens.size() - 3] + " " + tokens[tokens.size() - 2] + " " + tokens.back());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// convert --color -> export: every particle keeps its own 8-bit colour (matched by its grid
// position), in memory and out of core (spilled, several bins), with a property column beside.
TEST(ColorStore, EachParticleKeepsItsColourThroughConvertAndExport) {
  TempDir dir;
  const int n = 60000;
  const auto colors = write_color_xyz(dir / "c.xyz", n, 8, /*charge=*/true);
  for (const std::string budget : {"", "--memory-budget 2MiB --node-size 1000 --density-res 1000"}) {
    SCOPED_TRACE(budget);
    const fs::path store = dir / "c.mds", xyz = dir / "c.out.xyz", report = dir / "r.json", info = dir / "i.json";
    ASSERT_EQ(run_mdstream(fmt::format("convert {} --color --property charge {} -q -o {} --json-report {}",
                                       (dir / "c.xyz").string(), budget, store.string(), report.string())),
              0)
        << cli_stderr();
    std::ifstream fr(report);
    const json j = json::parse(fr);
    EXPECT_TRUE(j["color"].get<bool>());
    EXPECT_EQ(j["spilled"].get<bool>(), !budget.empty());
    const double half_step = (j["property"]["max"].get<double>() - j["property"]["min"].get<double>()) / 65535.0 / 2.0;
    if (!budget.empty()) {
      EXPECT_GT(j["bins"].get<uint64_t>(), 1u);
    }
    ASSERT_EQ(run_mdstream("info " + store.string() + " --json > " + info.string()), 0) << cli_stderr();
    std::ifstream fi(info);
    EXPECT_TRUE(json::parse(fi)["color"].get<bool>());
    ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + xyz.string()), 0) << cli_stderr();
    std::ifstream fx(xyz);
    std::string line;
    std::getline(fx, line);
    std::getline(fx, line);
    EXPECT_THAT(line, HasSubstr("Properties=species:S:1:pos:R:3:charge:R:1:color:R:3"));
    size_t count = 0, wrong = 0, wrong_charge = 0;
    while (std::getline(fx, line)) {
      std::istringstream s(line);
      std::string sp;
      double x, y, z, q, r, g, b;
      s >> sp >> x >> y >> z >> q >> r >> g >> b;
      const uint32_t c = pack_rgba8(uint32_t(std::lround(r * 255)), uint32_t(std::lround(g * 255)),
                                    uint32_t(std::lround(b * 255)));
      const int ix = int(std::lround(x)), iy = int(std::lround(y)), iz = int(std::lround(z));
      wrong += colors.at({ix, iy, iz}) != c;
      wrong_charge += std::abs(q - double(ix + 2 * iy - iz)) > half_step * 1.001 + 1e-5;
      ++count;
    }
    EXPECT_EQ(count, size_t(n));
    EXPECT_EQ(wrong, 0u);
    EXPECT_EQ(wrong_charge, 0u);  // the property beside the colour keeps its own word
    // The export converts back to the same colours (5 digits give the 8 bits back).
    const fs::path again = dir / "again.mds", again_xyz = dir / "again.xyz";
    ASSERT_EQ(run_mdstream("convert " + xyz.string() + " --color -q -o " + again.string()), 0) << cli_stderr();
    ASSERT_EQ(run_mdstream("export " + again.string() + " -o " + again_xyz.string()), 0) << cli_stderr();
    EXPECT_EQ(exported_colors(again_xyz), exported_colors(xyz));
  }
  // An input without colours: an error naming it, and no store.
  testing::write_text(dir / "d.lammpstrj",
                      "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS pp pp pp\n0 1\n0 1\n0 1\n"
                      "ITEM: ATOMS id type x y z\n1 1 0.5 0.5 0.5\n");
  EXPECT_NE(run_mdstream("convert " + (dir / "d.lammpstrj").string() + " --color -q -o " + (dir / "d.mds").string()), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("has no per-particle colours"));
  EXPECT_FALSE(fs::exists(dir / "d.mds"));
}

// A block whose particles carry their species' colour: --color-by color (and the default, auto)
// must render the image of --color-by type with those colours as --type-color, in memory and
// streamed through a pool smaller than the store (GPU sRGB decode in float against the CPU's in
// double). Fails when the shaders ignore the colours, swap channels, or the pool's colour copies
// are wrong.
TEST(ColorRender, OwnColoursEqualTheSameTypeColours) {
  TempDir dir;
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(0.0, 20.0);
  const int n = 6000;
  std::string text = fmt::format("{}\nProperties=species:S:1:pos:R:3:color:R:3\n", n);
  const char* channels[2] = {"0.117647 0.784314 0.235294", "0.784314 0.117647 0.705882"};  // #1ec83c, #c81eb4
  for (int i = 0; i < n; ++i) text += fmt::format("{} {:.6f} {:.6f} {:.6f} {}\n", "AB"[i % 2], u(rng), u(rng), u(rng), channels[i % 2]);
  testing::write_text(dir / "c.xyz", text);
  const std::string store = (dir / "c.mds").string(), plain = (dir / "p.mds").string();
  ASSERT_EQ(run_mdstream("convert " + (dir / "c.xyz").string() + " --color --node-size 500 -q -o " + store), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("convert " + (dir / "c.xyz").string() + " --node-size 500 -q -o " + plain), 0) << cli_stderr();
  auto render = [&](const std::string& s, const std::string& name, const std::string& args) {
    const fs::path exr = dir / (name + ".exr");
    EXPECT_EQ(run_mdstream("render " + s + " --width 96 --height 72 --spp 2 --no-cull --view 0 -o " + exr.string() + " " + args),
              0)
        << args << ": " << cli_stderr();
    return testing::load_exr(exr);
  };
  const std::vector<float> typed = render(plain, "t", "--type-color A=#1ec83c --type-color B=#c81eb4");
  const std::vector<float> by_default = render(store, "d", "");
  for (const char* where : {"", "--gpu-budget 96KiB"}) {
    SCOPED_TRACE(where);
    const std::vector<float> own = render(store, "c", std::string("--color-by color ") + where);
    ASSERT_EQ(own.size(), typed.size());
    double worst = 0.0;
    size_t covered = 0;
    for (size_t i = 0; i < own.size(); ++i) {
      worst = std::max(worst, double(std::abs(own[i] - typed[i])));
      covered += (i % 4 == 3 && typed[i] > 0.5f);
    }
    EXPECT_GT(covered, own.size() / 16);
    EXPECT_LT(worst, 1e-4);
    if (*where == '\0') {
      EXPECT_EQ(by_default, own);  // auto takes the store's colours
    }
  }
  // The type colours differ from those: the comparison can fail.
  const std::vector<float> types = render(store, "ty", "--color-by type");
  double diff = 0.0;
  for (size_t i = 0; i < types.size(); ++i) diff = std::max(diff, double(std::abs(types[i] - typed[i])));
  EXPECT_GT(diff, 0.1);
  // --pick names the colour of the particle it finds: its species' (no --no-cull needed).
  ASSERT_EQ(run_mdstream("render " + store + " --width 96 --height 72 --spp 1 --view 0 --pick 48,36 -o " +
                         (dir / "pick.png").string() + " > " + (dir / "pick.txt").string()),
            0)
      << cli_stderr();
  std::ifstream pf(dir / "pick.txt");
  std::string pick_line;
  ASSERT_TRUE(std::getline(pf, pick_line));
  const json pick = json::parse(pick_line)["particle"];
  EXPECT_EQ(pick["color"], pick["type_name"] == "A" ? "#1ec83c" : "#c81eb4") << pick_line;
  // Usage errors: colours asked of a store without them, and a legend of colours nothing explains.
  EXPECT_NE(run_mdstream("render " + plain + " --color-by color -o " + (dir / "x.png").string()), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("--color-by color: " + plain + " has no per-particle colours"));
  EXPECT_NE(run_mdstream("render " + store + " --color-legend top-left -o " + (dir / "x.png").string()), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("--color-legend: " + store + " is drawn in its particles' own colours"));
  EXPECT_FALSE(fs::exists(dir / "x.png"));
  EXPECT_EQ(run_mdstream("render " + store + " --color-by type --color-legend top-left --width 64 --height 48 -o " +
                         (dir / "x.png").string()),
            0)
      << cli_stderr();
}

// A series whose frames differ in colours: --color-by auto draws the particles' own colours
// only when every frame has them, so that an animation does not switch between colours and
// types; --color-by color is refused at the frame without them.
TEST(ColorRender, SeriesAutoTakesColoursOnlyWhenEveryFrameHasThem) {
  TempDir dir;
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(0.0, 12.0);
  std::string text = "800\nProperties=species:S:1:pos:R:3:color:R:3\n";
  for (int i = 0; i < 800; ++i) text += fmt::format("A {:.5f} {:.5f} {:.5f} 0.9 0.1 0.2\n", u(rng), u(rng), u(rng));
  testing::write_text(dir / "c.xyz", text);
  const std::string colored = (dir / "a.mds").string(), plain = (dir / "b.mds").string();
  ASSERT_EQ(run_mdstream("convert " + (dir / "c.xyz").string() + " --color -q -o " + colored), 0) << cli_stderr();
  ASSERT_EQ(run_mdstream("convert " + (dir / "c.xyz").string() + " -q -o " + plain), 0) << cli_stderr();
  testing::write_text(dir / "run.series", R"({ "file-series-version": "1.0", "files": [
    { "name": "a.mds", "time": 0 }, { "name": "b.mds", "time": 1 } ] })");
  const std::string common = " --width 64 --height 48 --spp 1 --no-cull --view 0 -o ";
  ASSERT_EQ(run_mdstream("render " + (dir / "run.series").string() + common + (dir / "f_%d.exr").string()), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("render " + colored + " --color-by type" + common + (dir / "typed.exr").string()), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("render " + colored + common + (dir / "own.exr").string()), 0) << cli_stderr();
  const std::vector<float> frame0 = testing::load_exr(dir / "f_0.exr"), typed = testing::load_exr(dir / "typed.exr");
  EXPECT_EQ(frame0, typed);  // the coloured frame drawn in its type's colour, as the plain one
  EXPECT_NE(frame0, testing::load_exr(dir / "own.exr"));
  EXPECT_NE(run_mdstream("render " + (dir / "run.series").string() + " --color-by color" + common +
                         (dir / "g_%d.exr").string()),
            0);
  EXPECT_THAT(cli_stderr(), HasSubstr("--color-by color: not every picked frame of " + (dir / "run.series").string()));
  EXPECT_FALSE(fs::exists(dir / "g_0.exr"));  // refused before any frame is written
}

}  // namespace
}  // namespace mds
