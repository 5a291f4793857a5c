// XYZ / extended XYZ reader on real data: LAMMPS' own `dump xyz` output (type ids as
// species) is compared with LAMMPS' custom dump of the same steps; plain and extended XYZ
// files written here from that LAMMPS output (element names, Properties in a non-default
// order, several frames, gzip) are read back; malformed variants must give errors of the
// right kind that name the file and the line.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "readers/reader_factories.h"
#include "readers/xyz_reader.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

using ::testing::HasSubstr;
using namespace textest;  // NOLINT(google-build-using-namespace): the shared test helpers
namespace fs = std::filesystem;

ReaderOptions frame_opt(int64_t f) { return frame_options(InputFormat::xyz, f); }

class XyzReaderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new textest::TempDir("xyz_reader");
    lj_ = new fs::path(textest::cached_lammps_run("in.lj_small"));
    ASSERT_FALSE(lj_->empty()) << "lmp failed on in.lj_small";
    frames_ = new std::vector<RefFrame>(parse_reference_dump(read_text(file("dump.unwrapped.lammpstrj"))));
  }
  static void TearDownTestSuite() {
    delete frames_;
    delete dir_;
    delete lj_;
  }
  // Output of LAMMPS (read only).
  static fs::path file(const std::string& name) { return *lj_ / name; }
  // A scratch file of this test process.
  static fs::path tmp(const std::string& name) { return dir_->path() / name; }
  static fs::path scratch(const std::string& name, const std::string& text) {
    write_text(tmp(name), text);
    return tmp(name);
  }
  static const char* element(int type) { return type == 1 ? "Ar" : "Kr"; }

  // Extended XYZ frame from LAMMPS frame k (its first n atoms), columns in a non-default order.
  static std::string extended_frame(size_t k, size_t n) {
    const RefFrame& f = (*frames_)[k];
    const double L = f.bounds[0][1] - f.bounds[0][0];
    std::string s = fmt::format("{}\n", n);
    s += fmt::format(
        "Lattice=\"{} 0 0 0 {} 0 0 0 {}\" Properties=id:I:1:pos:R:3:vel:R:3:species:S:1:radius:R:1 pbc=\"T T T\" "
        "Time=0.25 step={}\n",
        L, L, L, f.timestep);
    for (size_t i = 0; i < n; ++i)
      s += fmt::format("{} {} {} {} 0.1 -0.2 0.3 {} {}\n", f.col(i, "id"), f.col(i, "xu"), f.col(i, "yu"),
                       f.col(i, "zu"), element(static_cast<int>(f.col(i, "type"))), f.col(i, "radius"));
    return s;
  }

  static textest::TempDir* dir_;
  static fs::path* lj_;
  static std::vector<RefFrame>* frames_;
};
textest::TempDir* XyzReaderTest::dir_ = nullptr;
fs::path* XyzReaderTest::lj_ = nullptr;
std::vector<RefFrame>* XyzReaderTest::frames_ = nullptr;

TEST_F(XyzReaderTest, LammpsDumpXyzMatchesCustomDump) {
  for (int64_t f : {0, 2, -1}) {
    SCOPED_TRACE(f);
    auto x = read_all(open_xyz_reader(file("dump.types.xyz"), frame_opt(f)));
    auto c = read_all(open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(f)), 777);
    ASSERT_FALSE(x.error.has_value()) << x.error->message;
    ASSERT_FALSE(c.error.has_value()) << c.error->message;
    EXPECT_EQ(x.info.particle_count, 4000u);
    EXPECT_EQ(x.info.timestep, c.info.timestep);
    EXPECT_FALSE(x.info.has_box);
    EXPECT_FALSE(x.info.has_radius);
    EXPECT_EQ(x.all.x, c.all.x);
    EXPECT_EQ(x.all.y, c.all.y);
    EXPECT_EQ(x.all.z, c.all.z);
    EXPECT_EQ(x.all.type, c.all.type);  // integer species are the type ids
    EXPECT_TRUE(x.type_names.empty());
  }
}

TEST_F(XyzReaderTest, PlainXyzWithElementNamesAndExtraColumns) {
  const RefFrame& f = frames_->back();
  std::string s = fmt::format("{}\nplain xyz from LAMMPS step {}\n", f.natoms, f.timestep);
  for (size_t i = 0; i < f.natoms; ++i)
    s += fmt::format("{}\t{} {}  {} {} extra\n", element(static_cast<int>(f.col(i, "type"))), f.col(i, "xu"),
                     f.col(i, "yu"), f.col(i, "zu"), i);
  const fs::path p = scratch("plain.xyz", s);
  auto r = read_all(open_xyz_reader(p, frame_opt(0)), 1000);
  ASSERT_FALSE(r.error.has_value()) << r.error->message;
  ASSERT_EQ(r.all.size(), f.natoms);
  const std::string first = element(static_cast<int>(f.col(0, "type")));
  ASSERT_EQ(r.type_names.size(), 2u);
  EXPECT_EQ(r.type_names.at(1), first);  // first seen -> 1
  EXPECT_EQ(r.type_names.at(2), first == "Ar" ? "Kr" : "Ar");
  for (size_t i = 0; i < f.natoms; ++i) {
    ASSERT_EQ(r.type_names.at(r.all.type[i]), element(static_cast<int>(f.col(i, "type")))) << i;
    ASSERT_EQ(r.all.x[i], f.col(i, "xu"));
    ASSERT_EQ(r.all.y[i], f.col(i, "yu"));
    ASSERT_EQ(r.all.z[i], f.col(i, "zu"));
  }
  EXPECT_FALSE(r.info.has_box);
}

TEST_F(XyzReaderTest, ExtendedXyzPropertiesInAnotherOrder) {
  const fs::path p = scratch("ext.xyz", extended_frame(4, 4000));
  auto r = read_all(open_xyz_reader(p, frame_opt(0)));
  ASSERT_FALSE(r.error.has_value()) << r.error->message;
  const RefFrame& f = (*frames_)[4];
  ASSERT_EQ(r.all.size(), 4000u);
  EXPECT_EQ(r.info.timestep, f.timestep);
  EXPECT_TRUE(r.info.has_radius);
  EXPECT_TRUE(r.info.has_box);
  for (int d = 0; d < 3; ++d) {
    EXPECT_DOUBLE_EQ(r.info.box_lo[d], 0.0);
    EXPECT_DOUBLE_EQ(r.info.box_hi[d], f.bounds[0][1] - f.bounds[0][0]);
  }
  for (size_t i = 0; i < 4000; ++i) {
    ASSERT_EQ(r.all.x[i], f.col(i, "xu"));
    ASSERT_EQ(r.all.z[i], f.col(i, "zu"));
    ASSERT_EQ(r.all.radius[i], static_cast<float>(f.col(i, "radius")));
    ASSERT_EQ(r.type_names.at(r.all.type[i]), element(static_cast<int>(f.col(i, "type"))));
  }
}

TEST_F(XyzReaderTest, TriclinicLatticeGivesTheBoundingBox) {
  const fs::path p = scratch("tri.xyz",
                             "2\nLattice=\"10 0 0 2 8 0 -3 1 6\" Properties=pos:R:3:species:S:1\n"
                             "1 2 3 C\n4 5 6 O\n");
  auto r = read_all(open_xyz_reader(p, frame_opt(0)));
  ASSERT_FALSE(r.error.has_value()) << r.error->message;
  EXPECT_EQ(r.info.box_lo[0], -3);
  EXPECT_EQ(r.info.box_hi[0], 12);
  EXPECT_EQ(r.info.box_lo[1], 0);
  EXPECT_EQ(r.info.box_hi[1], 9);
  EXPECT_EQ(r.info.box_lo[2], 0);
  EXPECT_EQ(r.info.box_hi[2], 6);
  EXPECT_EQ(r.all.x[1], 4);
  EXPECT_EQ(r.type_names.at(r.all.type[1]), "O");
  // The cell itself: the vectors as rows, periodic along all three without pbc=.
  const double want[3][3] = {{10, 0, 0}, {2, 8, 0}, {-3, 1, 6}};
  for (int v = 0; v < 3; ++v) {
    EXPECT_EQ(r.info.cell.origin[v], 0.0);
    EXPECT_TRUE(r.info.cell.periodic[v]);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r.info.cell.vectors[v][k], want[v][k]);
  }
}

TEST_F(XyzReaderTest, OriginAndPbcOfTheCell) {
  const fs::path p = scratch("origin.xyz",
                             "1\nLattice=\"4 0 0 0 5 0 0 0 6\" Origin=\"-1 2.5 -3\" pbc=\"T F t\" "
                             "Properties=species:S:1:pos:R:3\nC 0 0 0\n");
  auto r = read_all(open_xyz_reader(p, frame_opt(0)));
  ASSERT_FALSE(r.error.has_value()) << r.error->message;
  const SimulationCell& c = r.info.cell;
  EXPECT_EQ(c.origin[0], -1);
  EXPECT_EQ(c.origin[1], 2.5);
  EXPECT_EQ(c.origin[2], -3);
  EXPECT_TRUE(c.periodic[0]);
  EXPECT_FALSE(c.periodic[1]);
  EXPECT_TRUE(c.periodic[2]);
  EXPECT_TRUE(c.orthogonal());
  EXPECT_EQ(r.info.box_lo[1], 2.5);
  EXPECT_EQ(r.info.box_hi[1], 7.5);

  const fs::path bad = scratch("badpbc.xyz",
                               "1\nLattice=\"4 0 0 0 5 0 0 0 6\" pbc=\"T maybe F\" Properties=species:S:1:pos:R:3\n"
                               "C 0 0 0\n");
  auto e = read_all(open_xyz_reader(bad, frame_opt(0)));
  ASSERT_TRUE(e.error.has_value());
  EXPECT_NE(e.error->message.find("badpbc.xyz:2: bad pbc value 'T maybe F'"), std::string::npos) << e.error->message;
  const fs::path four = scratch("fourpbc.xyz",
                                "1\nLattice=\"4 0 0 0 5 0 0 0 6\" pbc=\"T T T F\" Properties=species:S:1:pos:R:3\n"
                                "C 0 0 0\n");
  auto e4 = read_all(open_xyz_reader(four, frame_opt(0)));
  ASSERT_TRUE(e4.error.has_value());
  EXPECT_NE(e4.error->message.find("fourpbc.xyz:2: bad pbc value 'T T T F'"), std::string::npos) << e4.error->message;
}

TEST_F(XyzReaderTest, MultiFrameAndGzip) {
  std::string s;
  for (size_t k = 0; k < 3; ++k) s += extended_frame(k, 4000 - 100 * k);
  const fs::path p = scratch("multi.xyz", s);
  const fs::path gz = tmp("multi_xyz.gz");
  ASSERT_EQ(std::system(("gzip -c " + textest::quote(p.string()) + " > " + textest::quote(gz.string())).c_str()), 0);
  for (const fs::path& path : {p, gz}) {
    SCOPED_TRACE(path.string());
    for (int64_t f : {0, 1, 2, -1}) {
      const size_t k = f < 0 ? 2 : static_cast<size_t>(f);
      auto r = read_all(open_xyz_reader(path, frame_opt(f)), 999);
      ASSERT_FALSE(r.error.has_value()) << r.error->message;
      ASSERT_EQ(r.all.size(), 4000 - 100 * k);
      EXPECT_EQ(r.info.timestep, (*frames_)[k].timestep);
      EXPECT_EQ(r.all.y.back(), (*frames_)[k].col(r.all.size() - 1, "yu"));
    }
    auto out = open_xyz_reader(path, frame_opt(3));
    ASSERT_FALSE(out.ok());
    EXPECT_EQ(out.error().code, Errc::invalid_argument);
  }
}

// list_frames (the series converter's frame list): one entry per frame with its step and count,
// and each mark opens the same frame as its index does, for the plain and the gzip file.
TEST_F(XyzReaderTest, ListFramesAndTheirMarks) {
  std::string s;
  for (size_t k = 0; k < 3; ++k) s += extended_frame(k, 4000 - 100 * k);
  const fs::path p = scratch("list.xyz", s);
  const fs::path gz = tmp("list_xyz.gz");
  ASSERT_EQ(std::system(("gzip -c " + textest::quote(p.string()) + " > " + textest::quote(gz.string())).c_str()), 0);
  for (const fs::path& path : {p, gz}) {
    SCOPED_TRACE(path.string());
    auto frames = list_frames(path, {});
    ASSERT_TRUE(frames.ok()) << frames.error().message;
    ASSERT_EQ(frames->size(), 3u);
    for (size_t k = 0; k < 3; ++k) {
      const FrameEntry& e = (*frames)[k];
      EXPECT_EQ(e.index, int64_t(k));
      EXPECT_EQ(e.timestep, (*frames_)[k].timestep);
      EXPECT_EQ(e.particle_count, 4000 - 100 * k);
      EXPECT_EQ(e.mark.index, int64_t(k));
      ReaderOptions o = frame_opt(int64_t(k));
      o.start = e.mark;
      auto by_mark = read_all(open_xyz_reader(path, o), 999);
      auto by_index = read_all(open_xyz_reader(path, frame_opt(int64_t(k))), 999);
      ASSERT_FALSE(by_mark.error.has_value()) << by_mark.error->message;
      ASSERT_FALSE(by_index.error.has_value()) << by_index.error->message;
      EXPECT_EQ(by_mark.all.x, by_index.all.x);
      EXPECT_EQ(by_mark.all.z, by_index.all.z);
      EXPECT_EQ(by_mark.info.timestep, by_index.info.timestep);
    }
    // A mark that points into the atom lines is an error naming the offset, not another frame.
    ReaderOptions o = frame_opt(1);
    o.start = (*frames)[1].mark;
    o.start.offset += 40;
    auto bad = open_xyz_reader(path, o);
    ASSERT_FALSE(bad.ok());
    EXPECT_THAT(bad.error().message, ::testing::HasSubstr(path.string()));
  }
  // A truncated last frame: the list fails and names the line.
  const fs::path cut = scratch("cut.xyz", s.substr(0, s.size() - 200));
  auto frames = list_frames(cut, {});
  ASSERT_FALSE(frames.ok());
  EXPECT_THAT(frames.error().message, ::testing::HasSubstr("file ends inside the frame"));
}

TEST_F(XyzReaderTest, IntegerSpeciesCollidingWithANameIsAnError) {
  const fs::path p = scratch("mixed.xyz", "3\n\nC 0 0 0\nC 1 1 1\n1 2 2 2\n");
  expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::format, p, 5);
}

// --- malformed inputs ---

TEST_F(XyzReaderTest, Truncated) {
  const std::string text = extended_frame(0, 4000);
  for (size_t cut : {text.size() / 2, text.find('\n', text.size() / 3) + 1}) {
    const std::string part = text.substr(0, cut);
    const fs::path p = scratch("trunc.xyz", part);
    const uint64_t line = static_cast<uint64_t>(std::count(part.begin(), part.end(), '\n')) + 1;
    auto r = read_all(open_xyz_reader(p, frame_opt(0)));
    ASSERT_TRUE(r.error.has_value());
    // Cut inside a line (too few columns there, or the file ends inside the frame) or at a line boundary.
    EXPECT_EQ(r.error->code, Errc::format) << r.error->message;
    EXPECT_THAT(r.error->message, HasSubstr(p.string() + ":" + std::to_string(line) + ":"));
  }
  const fs::path c = scratch("trunc_comment.xyz", "5\n");
  expect_error(read_all(open_xyz_reader(c, frame_opt(0))), Errc::format, c, 1);
}

TEST_F(XyzReaderTest, NonFiniteCoordinate) {
  for (const char* bad : {"nan", "inf", "-Infinity", "1e400"}) {
    SCOPED_TRACE(bad);
    auto lines = split_lines(extended_frame(0, 4000));
    lines[2 + 3000] = fmt::format("3001 1 2 {} 0.1 -0.2 0.3 Ar 0.5", bad);
    const fs::path p = scratch("nan.xyz", join_lines(lines));
    expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::range, p, 3 + 3000);
  }
}

TEST_F(XyzReaderTest, WrongAtomCount) {
  std::string two = extended_frame(0, 500) + extended_frame(1, 400);
  // Declared too many in the first frame: the next frame's count line is read as an atom.
  {
    auto lines = split_lines(two);
    lines[0] = "501";
    const fs::path p = scratch("high.xyz", join_lines(lines));
    auto r = read_all(open_xyz_reader(p, frame_opt(0)));
    expect_error(r, Errc::format, p, 2 + 500 + 1);
    EXPECT_THAT(r.error->message, HasSubstr("count"));
    expect_error(read_all(open_xyz_reader(p, frame_opt(1))), Errc::format, p, 2 + 500 + 2);
  }
  // Declared too few: a leftover atom line where the next frame should start.
  {
    auto lines = split_lines(two);
    lines[0] = "499";
    const fs::path p = scratch("low.xyz", join_lines(lines));
    expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::format, p, 2 + 499 + 1);
    expect_error(read_all(open_xyz_reader(p, frame_opt(-1))), Errc::format, p, 2 + 499 + 1);
  }
}

TEST_F(XyzReaderTest, MissingOrExtraColumns) {
  {
    const fs::path p = scratch("short_plain.xyz", "3\ncomment\nC 0 0 0\nC 1 1\nC 2 2 2\n");
    expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::format, p, 4);
  }
  {
    auto lines = split_lines(extended_frame(0, 1000));
    lines[2 + 10] += " 9.0";  // one column more than Properties says
    const fs::path p = scratch("extra_ext.xyz", join_lines(lines));
    auto r = read_all(open_xyz_reader(p, frame_opt(0)));
    expect_error(r, Errc::format, p, 3 + 10);
    EXPECT_THAT(r.error->message, HasSubstr("expected 9 columns"));
  }
  {
    const fs::path p = scratch("nopos.xyz", "1\nProperties=species:S:1:vel:R:3\nC 0 0 0\n");
    expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::format, p, 2);
  }
  {
    const fs::path p = scratch("quote.xyz", "1\nLattice=\"1 0 0 0 1 0 0 0 1 Properties=species:S:1:pos:R:3\nC 0 0 0\n");
    expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::format, p, 2);
  }
}

TEST_F(XyzReaderTest, AbsurdAndBadCounts) {
  {
    const fs::path p = scratch("absurd.xyz", "1000000000000000000\ncomment\nC 0 0 0\n");
    expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::range, p, 1);
  }
  {
    const fs::path p = scratch("toolarge.xyz", "100000\ncomment\nC 0 0 0\n");
    expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::range, p, 1);
  }
  {
    const fs::path p = scratch("notcount.xyz", "C 0 0 0\ncomment\n");
    expect_error(read_all(open_xyz_reader(p, frame_opt(0))), Errc::format, p, 1);
  }
}

TEST(ExtXyzComment, KeyValuesQuotesBracesAndFlags) {
  std::map<std::string, std::string> kv;
  ASSERT_TRUE(parse_extxyz_comment(
      R"(Lattice="1 0 0 0 2 0 0 0 3" Properties=species:S:1:pos:R:3 pbc="T T F" flag c={1 2 3} d = 4 s="a \"q\"")",
      kv));
  EXPECT_EQ(kv["Lattice"], "1 0 0 0 2 0 0 0 3");
  EXPECT_EQ(kv["Properties"], "species:S:1:pos:R:3");
  EXPECT_EQ(kv["pbc"], "T T F");
  EXPECT_EQ(kv["flag"], "T");
  EXPECT_EQ(kv["c"], "1 2 3");
  EXPECT_EQ(kv["d"], "4");
  EXPECT_EQ(kv["s"], "a \"q\"");
  std::map<std::string, std::string> bad;
  EXPECT_FALSE(parse_extxyz_comment("a=\"open", bad));

  std::vector<XyzProperty> props;
  std::string err;
  ASSERT_TRUE(parse_extxyz_properties("id:I:1:pos:R:3:species:S:1", props, err)) << err;
  ASSERT_EQ(props.size(), 3u);
  EXPECT_EQ(props[1].first_column, 1);
  EXPECT_EQ(props[2].first_column, 4);
  EXPECT_FALSE(parse_extxyz_properties("pos:R", props, err));
  EXPECT_FALSE(parse_extxyz_properties("pos:Q:3", props, err));
}

}  // namespace
}  // namespace mds
