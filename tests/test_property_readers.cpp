// The per-particle property of the readers (ReaderOptions::property, `convert --property`): a
// LAMMPS column of real LAMMPS output (Debian's `lmp` on tests/data/lammps/in.property_small:
// per-atom potential energy and velocity), an extended-XYZ property, H5MD elements written by
// h5py, MMPLD intensities (tests/tools/write_mmpld.py), each against values parsed
// independently here; and the errors of a property that is not there, is a position column,
// has the wrong shape or a non-finite value, each naming the file and the place.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "binreader_test_util.h"
#include "h5md/h5md_reader.h"
#include "readers/mmpld_reader.h"
#include "readers/reader.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

using ::testing::HasSubstr;
using textest::read_all;
namespace fs = std::filesystem;

// The last frame of dump.property.lammpstrj parsed here: one row of numbers per atom, in the
// columns of its ITEM: ATOMS line.
struct Table {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  uint64_t atoms_line = 0;        // line of the last frame's ITEM: ATOMS
  uint64_t first_atoms_line = 0;  // line of the first frame's
  size_t column(const std::string& name) const {
    for (size_t i = 0; i < columns.size(); ++i)
      if (columns[i] == name) return i;
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
};

Table last_frame(const fs::path& dump) {
  std::ifstream f(dump);
  Table t;
  std::string line;
  uint64_t no = 0;
  size_t left = 0;
  while (std::getline(f, line)) {
    ++no;
    if (line.rfind("ITEM: ATOMS", 0) == 0) {
      std::istringstream s(line.substr(11));
      t.columns.clear();
      for (std::string c; s >> c;) t.columns.push_back(c);
      t.rows.clear();
      t.atoms_line = no;
      if (t.first_atoms_line == 0) t.first_atoms_line = no;
      left = SIZE_MAX;
      continue;
    }
    if (line.rfind("ITEM:", 0) == 0) {
      left = 0;
      continue;
    }
    if (left == SIZE_MAX || left > 0) {
      std::istringstream s(line);
      std::vector<double> row;
      for (double v; s >> v;) row.push_back(v);
      if (row.size() == t.columns.size()) t.rows.push_back(row);
    }
  }
  return t;
}

class PropertyLammps : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = textest::cached_lammps_run("in.property_small");
    ASSERT_FALSE(dir_.empty()) << "lmp failed on in.property_small";
  }
  static fs::path dump() { return dir_ / "dump.property.lammpstrj"; }
  static ReaderOptions options(const std::string& property) {
    ReaderOptions o = textest::frame_options(InputFormat::lammps, -1);
    o.property = property;
    return o;
  }
  static inline fs::path dir_;
};

TEST_F(PropertyLammps, ReadsTheNamedColumnOfEveryAtom) {
  const Table t = last_frame(dump());
  ASSERT_EQ(t.rows.size(), 864u);
  for (const char* name : {"c_pe", "vx"}) {
    SCOPED_TRACE(name);
    const auto r = read_all(open_reader(dump(), options(name)), 100);  // many batches
    ASSERT_FALSE(r.error.has_value()) << r.error->message;
    EXPECT_TRUE(r.info.has_property);
    ASSERT_EQ(r.all.property.size(), t.rows.size());
    const size_t c = t.column(name);
    double lo = 1e300, hi = -1e300;
    for (size_t i = 0; i < t.rows.size(); ++i) {
      ASSERT_EQ(r.all.property[i], float(t.rows[i][c])) << "atom " << i;
      lo = std::min(lo, t.rows[i][c]);
      hi = std::max(hi, t.rows[i][c]);
    }
    EXPECT_LT(lo, hi);  // step 100 of the NVE run: the values differ from atom to atom
  }
  // Without the option nothing is kept.
  const auto plain = read_all(open_reader(dump(), textest::frame_options(InputFormat::lammps, -1)));
  ASSERT_FALSE(plain.error.has_value());
  EXPECT_FALSE(plain.info.has_property);
  EXPECT_TRUE(plain.all.property.empty());
}

// Every frame's header is checked while the frame is sought: the first frame's names the error.
TEST_F(PropertyLammps, AMissingOrReservedColumnNamesTheFileAndTheAtomsLine) {
  const Table t = last_frame(dump());
  ASSERT_LT(t.first_atoms_line, t.atoms_line);
  const auto missing = read_all(open_reader(dump(), options("c_ke")));
  textest::expect_error(missing, Errc::format, dump(), t.first_atoms_line);
  EXPECT_THAT(missing.error->message, HasSubstr("no column 'c_ke'"));
  EXPECT_THAT(missing.error->message, HasSubstr("id type x y z c_pe vx"));
  for (const char* taken : {"x", "type", "id"}) {
    const auto r = read_all(open_reader(dump(), options(taken)));
    textest::expect_error(r, Errc::invalid_argument, dump(), t.first_atoms_line);
  }
}

TEST_F(PropertyLammps, ANonFiniteValueNamesItsLine) {
  textest::TempDir tmp("property");
  std::vector<std::string> lines = textest::split_lines(textest::read_text(dump()));
  const Table t = last_frame(dump());
  const uint64_t bad_line = t.atoms_line + 17;  // 1-based: the 17th atom of the last frame
  std::istringstream s(lines[bad_line - 1]);
  std::vector<std::string> tok;
  for (std::string w; s >> w;) tok.push_back(w);
  tok[t.column("c_pe")] = "nan";
  std::string joined;
  for (const auto& w : tok) joined += (joined.empty() ? "" : " ") + w;
  lines[bad_line - 1] = joined;
  const fs::path bad = tmp.path() / "nan.lammpstrj";
  textest::write_text(bad, textest::join_lines(lines));
  const auto r = read_all(open_reader(bad, options("c_pe")));
  textest::expect_error(r, Errc::range, bad, bad_line);
  EXPECT_THAT(r.error->message, HasSubstr("property 'c_pe'"));
  // The same file converts without the property: only the asked-for column is checked.
  EXPECT_FALSE(read_all(open_reader(bad, textest::frame_options(InputFormat::lammps, -1))).error.has_value());
}

TEST(PropertyXyz, ReadsAnExtendedXyzPropertyAndRejectsWhatIsNotOne) {
  textest::TempDir tmp("property");
  const fs::path f = tmp.path() / "p.xyz";
  textest::write_text(f,
                      "3\nProperties=species:S:1:pos:R:3:charge:R:1:tag:S:1:vel:R:3 step=4\n"
                      "Cu 0 0 0 -0.5 a 1 2 3\nO 1 0 0 1.25e3 b 4 5 6\nCu 0 1 0 +2 c 7 8 9\n");
  ReaderOptions o = textest::frame_options(InputFormat::xyz, 0);
  o.property = "charge";
  const auto r = read_all(open_reader(f, o));
  ASSERT_FALSE(r.error.has_value()) << r.error->message;
  EXPECT_THAT(r.all.property, ::testing::ElementsAre(-0.5f, 1250.0f, 2.0f));
  for (const char* bad : {"mass", "tag", "vel", "pos", "species"}) {
    o.property = bad;
    const auto e = read_all(open_reader(f, o));
    textest::expect_error(e, std::string(bad) == "pos" || std::string(bad) == "species" ? Errc::invalid_argument
                                                                                        : Errc::format,
                          f, 2);
  }
  const fs::path plain = tmp.path() / "plain.xyz";
  textest::write_text(plain, "1\ncomment\nAr 0 0 0\n");
  o.property = "charge";
  const auto e = read_all(open_reader(plain, o));
  textest::expect_error(e, Errc::format, plain, 2);
  EXPECT_THAT(e.error->message, HasSubstr("extended XYZ"));
}

TEST(PropertyRaw, RawInputHasNoProperty) {
  textest::TempDir tmp("property");
  const fs::path f = tmp.path() / "p.f32";
  const float xyz[6] = {0, 0, 0, 1, 1, 1};
  testing::write_bytes(f, xyz, sizeof xyz);
  ReaderOptions o = textest::frame_options(InputFormat::raw, 0);
  o.property = "charge";
  const auto r = open_reader(f, o);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr(f.string()));
  EXPECT_THAT(r.error().message, HasSubstr("'charge'"));
}

// h5py writes a time-dependent charge [2][N] (and [2][N][1]), a time-independent mass [N], a
// string element, a charge of the wrong length and one with a NaN.
class PropertyH5md : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    const fs::path script = *dir_ / "write.py";
    testing::write_text(script, R"(import sys, os, numpy as np, h5py
os.chdir(sys.argv[1])
rng = np.random.default_rng(7)
n = 50
pos = rng.random((2, n, 3)) * 10
charge = rng.normal(size=(2, n))
mass = rng.random(n) + 1
def base(f):
    f.create_group("h5md")
    g = f.create_group("particles/atoms")
    g.create_group("position").create_dataset("value", data=pos)
    return g
with h5py.File("good.h5md", "w") as f:
    g = base(f)
    g.create_group("charge").create_dataset("value", data=charge.astype("f4"))
    g.create_group("charge3").create_dataset("value", data=charge[:, :, None])
    g.create_dataset("mass", data=mass)
    g.create_dataset("count", data=np.arange(n, dtype="i8"))
    g.create_dataset("name", data=np.array([b"a"] * n))
    g.create_group("short").create_dataset("value", data=charge[:, :-1])
    bad = charge.copy(); bad[1, 33] = np.nan
    g.create_group("nan").create_dataset("value", data=bad)
np.savetxt("charge.txt", charge.astype("f4")[1], fmt="%.9g")
np.savetxt("mass.txt", mass, fmt="%.17g")
)");
    ASSERT_EQ(testing::run_python({script.string(), dir_->path().string()}), 0);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static Result<testing::AllParticles> read(const std::string& property) {
    ReaderOptions o;
    o.frame = -1;
    o.property = property;
    MDS_ASSIGN_OR_RETURN(auto r, H5mdReader::open(*dir_ / "good.h5md", o));
    EXPECT_TRUE(r->info().has_property);
    return testing::read_all(*r, 16);
  }
  static std::vector<double> column(const std::string& file) {
    std::ifstream f(*dir_ / file);
    std::vector<double> v;
    for (double x; f >> x;) v.push_back(x);
    return v;
  }
  static inline testing::TempDir* dir_ = nullptr;
};

TEST_F(PropertyH5md, ReadsTimeDependentAndFixedElements) {
  const std::vector<double> charge = column("charge.txt"), mass = column("mass.txt");
  ASSERT_EQ(charge.size(), 50u);
  for (const char* name : {"charge", "charge3"}) {
    auto all = read(name);
    ASSERT_TRUE(all.ok()) << all.error().message;
    ASSERT_EQ(all->property.size(), 50u);
    for (size_t i = 0; i < 50; ++i) EXPECT_EQ(all->property[i], float(charge[i])) << name << " " << i;
  }
  auto m = read("mass");
  ASSERT_TRUE(m.ok()) << m.error().message;
  for (size_t i = 0; i < 50; ++i) EXPECT_EQ(m->property[i], float(mass[i]));
  auto c = read("count");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->property[49], 49.0f);
}

TEST_F(PropertyH5md, MissingWrongShapeAndNonFiniteNameTheDataset) {
  const std::string file = (*dir_ / "good.h5md").string();
  for (const auto& [name, want] : std::vector<std::pair<std::string, std::string>>{
           {"velocity", "no element /particles/atoms/velocity"},
           {"short", "dataset /particles/atoms/short/value has shape"},
           {"name", "dataset /particles/atoms/name is not numeric"},
           {"nan", "dataset /particles/atoms/nan/value: frame 1 particle 33"}}) {
    auto r = read(name);
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_THAT(r.error().message, HasSubstr(file)) << name;
    EXPECT_THAT(r.error().message, HasSubstr(want)) << name;
  }
}

TEST(PropertyMmpld, KeepsFloatAndDoubleIntensities) {
  testing::TempDir dir;
  const nlohmann::json spec = {
      {"version", 103},
      {"seed", 3},
      {"frames", {{{"lists", {{{"vertex", 1}, {"colour", 3}, {"count", 40}, {"radius", 0.5}},
                              {{"vertex", 0}, {"colour", 1}, {"count", 0}},
                              {{"vertex", 4}, {"colour", 7}, {"count", 30}, {"radius", 0.7}}}}}}}};
  const nlohmann::json rgb = {{"version", 102},
                              {"seed", 4},
                              {"frames", {{{"lists", {{{"vertex", 2}, {"colour", 3}, {"count", 5}},
                                                      {{"vertex", 1}, {"colour", 1}, {"count", 5}}}}}}}};
  std::vector<std::string> args{testing::source_path("tests/tools/write_mmpld.py")};
  for (const auto& [s, name] : {std::pair{spec, std::string("i")}, std::pair{rgb, std::string("rgb")}}) {
    testing::write_text(dir / (name + ".json"), s.dump());
    args.insert(args.end(), {(dir / (name + ".json")).string(), (dir / (name + ".mmpld")).string(),
                             (dir / (name + ".expected.json")).string()});
  }
  ASSERT_EQ(testing::run_python(args), 0);
  std::ifstream ef(dir / "i.expected.json");
  const nlohmann::json exp = nlohmann::json::parse(ef)["frames"][0]["intensity"];
  ASSERT_EQ(exp.size(), 70u);
  ReaderOptions o;
  o.property = "intensity";
  auto r = MmpldReader::open(dir / "i.mmpld", o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto all = testing::read_all(**r, 7);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->property.size(), 70u);
  for (size_t i = 0; i < 70; ++i) EXPECT_EQ(all->property[i], float(exp[i].get<double>())) << i;

  auto mixed = MmpldReader::open(dir / "rgb.mmpld", o);
  ASSERT_FALSE(mixed.ok());
  EXPECT_THAT(mixed.error().message, HasSubstr((dir / "rgb.mmpld").string() + ": byte offset"));
  EXPECT_THAT(mixed.error().message, HasSubstr("list 1: colour type 1 carries no intensity"));
  o.property = "charge";
  auto other = MmpldReader::open(dir / "i.mmpld", o);
  ASSERT_FALSE(other.ok());
  EXPECT_THAT(other.error().message, HasSubstr("no property 'charge'"));
}

}  // namespace
}  // namespace mds
