// `mdstream export STORE -o OUT.mmpld` (cli/export_mmpld.cpp): MMPLD 1.0 for MegaMol, read back
// by the MMPLD reader (tests/test_mmpld_reader.cpp checks that reader against an independent
// Python writer) and compared particle by particle with the extended XYZ export of the same
// store: float32 positions, per-particle radii, the store's colours, its property as FLOAT_I
// intensities, the types' default colours as the lists' global colours, slices; and the errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "binreader_test_util.h"
#include "cli_test_util.h"
#include "readers/mmpld_reader.h"
#include "store/type_style.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::run_mdstream;
using testing::TempDir;

// One particle as both exports give it: type id (MMPLD list index + 1; in the XYZ export the
// species' position among the store's types + 1), float32 position, radius, and the 4-byte
// extra (RGBA8, or the property's float bits).
using Row = std::tuple<int32_t, float, float, float, float, uint32_t>;

// The XYZ export of `store` as rows: columns species x y z [radius] [property] [r g b].
std::vector<Row> xyz_rows(const fs::path& store, const fs::path& xyz, const std::vector<std::string>& species,
                          bool radius, bool property, bool color, float type_radius, const std::string& slice = "") {
  EXPECT_EQ(run_mdstream("export " + store.string() + " -o " + xyz.string() + slice), 0) << cli_stderr();
  std::ifstream f(xyz);
  std::string line;
  std::getline(f, line);
  std::getline(f, line);
  std::vector<Row> rows;
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string sp;
    double x, y, z, r = type_radius, p = 0, cr = 0, cg = 0, cb = 0;
    s >> sp >> x >> y >> z;
    if (radius) s >> r;
    if (property) s >> p;
    if (color) s >> cr >> cg >> cb;
    const int32_t type = int32_t(std::find(species.begin(), species.end(), sp) - species.begin()) + 1;
    const uint32_t extra = color ? pack_rgba8(uint32_t(std::lround(cr * 255)), uint32_t(std::lround(cg * 255)),
                                              uint32_t(std::lround(cb * 255)))
                                 : property ? std::bit_cast<uint32_t>(float(p)) : 0u;
    rows.emplace_back(type, float(x), float(y), float(z), float(r), extra);
  }
  std::sort(rows.begin(), rows.end());
  return rows;
}

// The MMPLD file read back as rows (colours kept, or the intensity as the property).
std::vector<Row> mmpld_rows(const fs::path& mmpld, bool color, bool property, float type_radius) {
  ReaderOptions o;
  o.color = color;
  if (property) o.property = "intensity";
  auto r = open_reader(mmpld, o);
  EXPECT_TRUE(r.ok()) << r.error().message;
  if (!r.ok()) return {};
  auto all = testing::read_all(**r, 1000);
  EXPECT_TRUE(all.ok()) << all.error().message;
  std::vector<Row> rows;
  for (size_t i = 0; i < all->x.size(); ++i) {
    const float rad = all->radius.empty() ? type_radius : all->radius[i];
    const uint32_t extra = color ? all->color[i] : property ? std::bit_cast<uint32_t>(all->property[i]) : 0u;
    rows.emplace_back(all->type[i], float(all->x[i]), float(all->y[i]), float(all->z[i]), rad, extra);
  }
  std::sort(rows.begin(), rows.end());
  return rows;
}

// Two species A, B with their own colours, in a 20^3 box.
TEST(ExportMmpld, ColoursAndTypesAsMegaMolListsAndThroughSlices) {
  TempDir dir;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 20.0);
  std::string text = "3000\nProperties=species:S:1:pos:R:3:color:R:3\n";
  for (int i = 0; i < 3000; ++i) {  // B only at x < 5
    const bool b = i % 3 == 0;
    const double x = b ? u(rng) / 4 : u(rng);
    text += fmt::format("{} {:.5f} {:.5f} {:.5f} {:.4f} {:.4f} {:.4f}\n", b ? "B" : "A", x, u(rng), u(rng),
                        (rng() % 256) / 255.0, (rng() % 256) / 255.0, (rng() % 256) / 255.0);
  }
  testing::write_text(dir / "c.xyz", text);
  const fs::path store = dir / "c.mds", mmpld = dir / "c.mmpld";
  ASSERT_EQ(run_mdstream("convert " + (dir / "c.xyz").string() + " --color --radius 0.4 --node-size 300 -q -o " +
                         store.string()),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + mmpld.string()), 0) << cli_stderr();
  auto opened = MmpldReader::open(mmpld, {});
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  const auto& m = dynamic_cast<const MmpldReader&>(**opened);
  EXPECT_EQ(m.version(), 100);
  EXPECT_EQ(m.frame_count(), 1u);
  ASSERT_EQ(m.lists().size(), 2u);  // one per type
  for (const MmpldList& l : m.lists()) {
    EXPECT_EQ(l.vertex_type, 1);  // FLOAT_XYZ
    EXPECT_EQ(l.colour_type, 2);  // UINT8_RGBA
    EXPECT_FLOAT_EQ(l.global_radius, 0.4f);
  }
  EXPECT_EQ(m.lists()[0].count + m.lists()[1].count, 3000u);
  // The species in type-index order (the store's type table, as info lists it).
  ASSERT_EQ(run_mdstream("info " + store.string() + " --json > " + (dir / "info.json").string()), 0) << cli_stderr();
  std::ifstream fi(dir / "info.json");
  std::vector<std::string> species;
  const nlohmann::json info = nlohmann::json::parse(fi);
  for (const auto& t : info["types"]) species.push_back(t["name"].get<std::string>());
  ASSERT_EQ(species.size(), 2u);
  const std::vector<Row> want = xyz_rows(store, dir / "c.out.xyz", species, false, false, true, 0.4f);
  ASSERT_EQ(want.size(), 3000u);
  EXPECT_EQ(mmpld_rows(mmpld, true, false, 0.4f), want);

  // With a slice: the particles the XYZ export keeps, and nothing else.
  const std::string slice = " --slice 1,0,0,10";
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + (dir / "s.mmpld").string() + slice), 0) << cli_stderr();
  const std::vector<Row> kept = xyz_rows(store, dir / "s.xyz", species, false, false, true, 0.4f, slice);
  EXPECT_GT(kept.size(), 500u);
  EXPECT_LT(kept.size(), 2500u);
  EXPECT_EQ(mmpld_rows(dir / "s.mmpld", true, false, 0.4f), kept);

  // A slice that keeps no B (x >= 6): B's list is there, empty, and the file reads back.
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + (dir / "a.mmpld").string() + " --slice -1,0,0,-6"), 0)
      << cli_stderr();
  auto only_a = MmpldReader::open(dir / "a.mmpld", {});
  ASSERT_TRUE(only_a.ok()) << only_a.error().message;
  const auto& am = dynamic_cast<const MmpldReader&>(**only_a);
  ASSERT_EQ(am.lists().size(), 2u);
  const size_t b_list = size_t(std::find(species.begin(), species.end(), "B") - species.begin());
  EXPECT_EQ(am.lists()[b_list].count, 0u);
  EXPECT_GT(am.lists()[1 - b_list].count, 1000u);
  EXPECT_EQ(mmpld_rows(dir / "a.mmpld", true, false, 0.4f),
            xyz_rows(store, dir / "a.xyz", species, false, false, true, 0.4f, " --slice -1,0,0,-6"));

  // Errors leave no file: a slice that keeps nothing, an unwritable place.
  EXPECT_NE(run_mdstream("export " + store.string() + " -o " + (dir / "none.mmpld").string() + " --slice 1,0,0,-1000"), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("--slice leaves no particle"));
  EXPECT_FALSE(fs::exists(dir / "none.mmpld"));
  EXPECT_NE(run_mdstream("export " + store.string() + " -o " + (dir / "no/such/dir.mmpld").string()), 0);
  EXPECT_FALSE(fs::exists(dir / "no"));
  // The extension in any case.
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + (dir / "upper.MMPLD").string()), 0) << cli_stderr();
  EXPECT_TRUE(MmpldReader::open(dir / "upper.MMPLD", {}).ok());
}

// A LAMMPS dump with per-particle radii and a property column: FLOAT_XYZR lists whose FLOAT_I
// intensities are the property (intensity range = the store's property range); a store without
// either: NONE lists with the types' default colours.
TEST(ExportMmpld, RadiiAndPropertyOrTheTypesColours) {
  TempDir dir;
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(0.0, 15.0);
  std::string text =
      "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2000\nITEM: BOX BOUNDS pp pp pp\n0 15\n0 15\n0 15\n"
      "ITEM: ATOMS id type x y z radius q\n";
  for (int i = 0; i < 2000; ++i)
    text += fmt::format("{} {} {:.5f} {:.5f} {:.5f} {:.4f} {:.5f}\n", i + 1, 1 + i % 3, u(rng), u(rng), u(rng),
                        0.2 + 0.3 * (rng() % 1000) / 1000.0, u(rng) - 7.5);
  testing::write_text(dir / "d.lammpstrj", text);
  const fs::path store = dir / "d.mds";
  ASSERT_EQ(run_mdstream("convert " + (dir / "d.lammpstrj").string() + " --property q --node-size 300 -q -o " +
                         store.string()),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + (dir / "d.mmpld").string()), 0) << cli_stderr();
  auto opened = MmpldReader::open(dir / "d.mmpld", {});
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  const auto& m = dynamic_cast<const MmpldReader&>(**opened);
  ASSERT_EQ(m.lists().size(), 3u);
  ASSERT_EQ(run_mdstream("info " + store.string() + " --json > " + (dir / "info.json").string()), 0) << cli_stderr();
  std::ifstream fi(dir / "info.json");
  const nlohmann::json info = nlohmann::json::parse(fi);
  for (const MmpldList& l : m.lists()) {
    EXPECT_EQ(l.vertex_type, 2);  // FLOAT_XYZR
    EXPECT_EQ(l.colour_type, 3);  // FLOAT_I
    EXPECT_EQ(l.intensity_range[0], info["property"]["min"].get<float>());
    EXPECT_EQ(l.intensity_range[1], info["property"]["max"].get<float>());
    EXPECT_LT(l.intensity_range[0], l.intensity_range[1]);
  }
  EXPECT_EQ(mmpld_rows(dir / "d.mmpld", false, true, 0.0f),
            xyz_rows(store, dir / "d.xyz", {"1", "2", "3"}, true, true, false, 0.0f));

  // Without radius and property columns (the XYZ export above, its positions only): the types'
  // radii and default colours.
  std::ifstream f(dir / "d.xyz");
  std::string line;
  std::getline(f, line);
  std::string positions = line + "\nProperties=species:S:1:pos:R:3\n";
  std::getline(f, line);
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string sp, x, y, z;
    s >> sp >> x >> y >> z;
    positions += sp + " " + x + " " + y + " " + z + "\n";
  }
  testing::write_text(dir / "q.xyz", positions);
  const fs::path typed = dir / "q.mds";
  ASSERT_EQ(run_mdstream("convert " + (dir / "q.xyz").string() + " --radius 0.3 -q -o " + typed.string()), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + typed.string() + " -o " + (dir / "q.mmpld").string()), 0) << cli_stderr();
  ReaderOptions o;
  o.color = true;
  auto q = MmpldReader::open(dir / "q.mmpld", o);
  ASSERT_TRUE(q.ok()) << q.error().message;
  const auto& qm = dynamic_cast<const MmpldReader&>(**q);
  ASSERT_EQ(qm.lists().size(), 3u);
  for (size_t t = 0; t < 3; ++t) {
    const MmpldList& l = qm.lists()[t];
    EXPECT_EQ(l.vertex_type, 1);
    EXPECT_EQ(l.colour_type, 0);  // NONE: the list's global colour
    EXPECT_FLOAT_EQ(l.global_radius, 0.3f);
    const store::Srgb c = store::default_type_color(uint32_t(t));
    EXPECT_EQ(l.global_colour, pack_rgba8(uint32_t(std::lround(c.r * 255)), uint32_t(std::lround(c.g * 255)),
                                          uint32_t(std::lround(c.b * 255))))
        << t;
  }
}

// A store with a triclinic cell (LAMMPS' box): the MMPLD's bounding box is the cell's (as float),
// which the MMPLD reader takes back as a cell that is not periodic; without a cell it is the
// spheres' box (the test above). Every centre lies in the box.
TEST(ExportMmpld, BoundingBoxIsTheSimulationCells) {
  const fs::path lmp = textest::cached_lammps_run("in.triclinic_small", /*with_log=*/true);
  ASSERT_FALSE(lmp.empty()) << "lmp failed on in.triclinic_small";
  TempDir dir;
  const fs::path store = dir / "t.mds", mmpld = dir / "t.mmpld";
  ASSERT_EQ(run_mdstream("convert -q --wrap " + (lmp / "tri.xyz.lammpstrj").string() + " -o " + store.string() +
                         " --json-report " + (dir / "r.json").string()),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + mmpld.string()), 0) << cli_stderr();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(dir / "r.json"));
  ASSERT_FALSE(j["cell"].is_null());
  SimulationCell c;
  for (int d = 0; d < 3; ++d) {
    c.origin[d] = j["cell"]["origin"][d];
    for (int k = 0; k < 3; ++k) c.vectors[d][k] = j["cell"]["vectors"][d][k];
  }
  ASSERT_FALSE(c.orthogonal());
  double lo[3], hi[3];
  c.bounds(lo, hi);
  auto r = open_reader(mmpld, {});
  ASSERT_TRUE(r.ok()) << r.error().message;
  const FrameInfo& fi = (*r)->info();
  ASSERT_TRUE(fi.has_box);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(fi.box_lo[k], double(float(lo[k]))) << k;
    EXPECT_EQ(fi.box_hi[k], double(float(hi[k]))) << k;
    EXPECT_FALSE(fi.cell.periodic[k]);
  }
  auto all = testing::read_all(**r, 1000);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_GT(all->x.size(), 1000u);
  for (size_t i = 0; i < all->x.size(); ++i) {
    const double p[3] = {all->x[i], all->y[i], all->z[i]};
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(p[k], fi.box_lo[k] - 1e-4) << i;
      EXPECT_LE(p[k], fi.box_hi[k] + 1e-4) << i;
    }
  }
}

}  // namespace
}  // namespace mds
