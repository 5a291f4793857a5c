// LAMMPS text dump reader on real LAMMPS output: Debian's `lmp` runs the decks in
// tests/data/lammps once per test program; the reader's particles are compared with an
// independent parse of the same files, scaled/unwrapped/compressed variants with the
// Cartesian dump of the same steps, and malformed variants of the real files must give
// errors of the right kind that name the file and the line.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>

#include "readers/lammps_reader.h"
#include "readers/reader_factories.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

using ::testing::HasSubstr;
using namespace textest;  // NOLINT(google-build-using-namespace): the shared test helpers
namespace fs = std::filesystem;

ReaderOptions frame_opt(int64_t f) { return frame_options(InputFormat::lammps, f); }

class LammpsReaderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new textest::TempDir("lammps_reader");
    lj_ = new fs::path(textest::cached_lammps_run("in.lj_small"));
    tri_ = new fs::path(textest::cached_lammps_run("in.triclinic_small", /*with_log=*/true));
    ASSERT_FALSE(lj_->empty()) << "lmp failed on in.lj_small";
    ASSERT_FALSE(tri_->empty()) << "lmp failed on in.triclinic_small";
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete lj_;
    delete tri_;
  }
  // Output of LAMMPS (read only).
  static fs::path file(const std::string& name) {
    return (name.rfind("tri", 0) == 0 || name == "log.lammps" ? *tri_ : *lj_) / name;
  }
  // A scratch file of this test process.
  static fs::path tmp(const std::string& name) { return dir_->path() / name; }
  static std::vector<RefFrame> reference(const std::string& name) {
    return parse_reference_dump(read_text(file(name)));
  }
  // Writes `text` to a new file in the temp dir and returns its path.
  static fs::path scratch(const std::string& name, const std::string& text) {
    fs::path p = tmp(name);
    write_text(p, text);
    return p;
  }
  // The first frame of the default-format dump, as lines.
  static std::vector<std::string> first_frame_lines() {
    auto lines = split_lines(read_text(file("dump.default.lammpstrj")));
    const size_t n = std::stoul(lines[3]);
    lines.resize(9 + n);
    return lines;
  }

  static textest::TempDir* dir_;
  static fs::path* lj_;
  static fs::path* tri_;
};
textest::TempDir* LammpsReaderTest::dir_ = nullptr;
fs::path* LammpsReaderTest::lj_ = nullptr;
fs::path* LammpsReaderTest::tri_ = nullptr;


void expect_same_as_reference(const ReadAll& r, const RefFrame& ref) {
  ASSERT_FALSE(r.error.has_value()) << r.error->message;
  ASSERT_EQ(r.info.particle_count, ref.natoms);
  EXPECT_EQ(r.info.timestep, ref.timestep);
  ASSERT_EQ(r.all.size(), ref.natoms);
  ASSERT_EQ(r.all.id.size(), ref.natoms);
  EXPECT_TRUE(r.info.has_box);
  for (int d = 0; d < 3; ++d) {
    EXPECT_EQ(r.info.box_lo[d], ref.bounds[d][0]);
    EXPECT_EQ(r.info.box_hi[d], ref.bounds[d][1]);
  }
  for (size_t i = 0; i < ref.natoms; ++i) {
    ASSERT_EQ(r.all.id[i], static_cast<int64_t>(ref.col(i, "id"))) << i;
    ASSERT_EQ(r.all.type[i], static_cast<int32_t>(ref.col(i, "type"))) << i;
    ASSERT_EQ(r.all.x[i], ref.col(i, "x")) << i;
    ASSERT_EQ(r.all.y[i], ref.col(i, "y")) << i;
    ASSERT_EQ(r.all.z[i], ref.col(i, "z")) << i;
  }
}

// Positions of two reads agree within tol (absolute), atoms in the same (id-sorted) order.
void expect_positions_near(const ReadAll& a, const ReadAll& b, double tol) {
  ASSERT_FALSE(a.error.has_value()) << a.error->message;
  ASSERT_FALSE(b.error.has_value()) << b.error->message;
  ASSERT_EQ(a.all.size(), b.all.size());
  ASSERT_EQ(a.all.id, b.all.id);
  EXPECT_EQ(a.all.type, b.all.type);
  for (size_t i = 0; i < a.all.size(); ++i) {
    ASSERT_NEAR(a.all.x[i], b.all.x[i], tol) << "id " << a.all.id[i];
    ASSERT_NEAR(a.all.y[i], b.all.y[i], tol) << "id " << a.all.id[i];
    ASSERT_NEAR(a.all.z[i], b.all.z[i], tol) << "id " << a.all.id[i];
  }
}

TEST_F(LammpsReaderTest, CartesianFramesMatchIndependentParse) {
  const auto ref = reference("dump.xyz.lammpstrj");
  ASSERT_EQ(ref.size(), 5u);
  for (int64_t f : {0, 1, 2, 4}) {
    SCOPED_TRACE(f);
    expect_same_as_reference(read_all(open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(f))),
                             ref[static_cast<size_t>(f)]);
  }
  auto last = read_all(open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(-1)));
  expect_same_as_reference(last, ref.back());
  EXPECT_EQ(last.info.timestep, 200);
  EXPECT_FALSE(last.info.has_radius);
  EXPECT_TRUE(last.all.radius.empty());
}

TEST_F(LammpsReaderTest, SmallBatchesGiveTheSameParticles) {
  auto big = read_all(open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(3)));
  auto small = read_all(open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(3)), 333);
  ASSERT_FALSE(small.error.has_value()) << small.error->message;
  EXPECT_EQ(big.all.x, small.all.x);
  EXPECT_EQ(big.all.id, small.all.id);
  EXPECT_EQ(big.all.type, small.all.type);
}

TEST_F(LammpsReaderTest, ReadAfterTheEndReturnsZero) {
  auto r = open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(0));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ParticleBatch b;
  size_t total = 0;
  for (int i = 0; i < 100; ++i) {
    auto n = (*r)->read(b, 1000);
    ASSERT_TRUE(n.ok()) << n.error().message;
    total += *n;
    if (*n == 0) break;
  }
  EXPECT_EQ(total, 4000u);
  auto again = (*r)->read(b, 1000);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, 0u);
}

TEST_F(LammpsReaderTest, FrameOutOfRangeIsAnError) {
  auto r = open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(5));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::invalid_argument);
  EXPECT_THAT(r.error().message, HasSubstr("5 frames"));
  auto neg = open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(-2));
  ASSERT_FALSE(neg.ok());
  EXPECT_EQ(neg.error().code, Errc::invalid_argument);
}

TEST_F(LammpsReaderTest, ScaledColumnsInAnotherOrderMatchCartesian) {
  const double L = reference("dump.xyz.lammpstrj")[0].bounds[0][1];
  for (int64_t f : {0, 2, -1}) {
    SCOPED_TRACE(f);
    auto cart = read_all(open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(f)));
    auto scaled = read_all(open_lammps_reader(file("dump.scaled.lammpstrj"), frame_opt(f)));
    expect_positions_near(scaled, cart, 1e-12 * L * 10);
  }
}

TEST_F(LammpsReaderTest, UnwrappedWithRadiusColumn) {
  const auto ref = reference("dump.unwrapped.lammpstrj");
  auto wrapped = read_all(open_lammps_reader(file("dump.xyz.lammpstrj"), frame_opt(-1)));
  auto unwrapped = read_all(open_lammps_reader(file("dump.unwrapped.lammpstrj"), frame_opt(-1)));
  ASSERT_FALSE(unwrapped.error.has_value()) << unwrapped.error->message;
  EXPECT_TRUE(unwrapped.info.has_radius);
  const RefFrame& last = ref.back();
  ASSERT_EQ(unwrapped.all.radius.size(), last.natoms);
  const double L[3] = {last.bounds[0][1] - last.bounds[0][0], last.bounds[1][1] - last.bounds[1][0],
                       last.bounds[2][1] - last.bounds[2][0]};
  size_t crossed = 0;
  for (size_t i = 0; i < last.natoms; ++i) {
    ASSERT_EQ(unwrapped.all.radius[i], static_cast<float>(last.col(i, "radius")));
    // The deck sets diameter 1.0 for type 1 and 0.8 for type 2.
    ASSERT_FLOAT_EQ(unwrapped.all.radius[i], unwrapped.all.type[i] == 1 ? 0.5f : 0.4f);
    ASSERT_EQ(unwrapped.all.x[i], last.col(i, "xu"));
    // Unwrapped minus wrapped is a whole number of box lengths.
    const double u[3] = {unwrapped.all.x[i], unwrapped.all.y[i], unwrapped.all.z[i]};
    const double w[3] = {wrapped.all.x[i], wrapped.all.y[i], wrapped.all.z[i]};
    for (int d = 0; d < 3; ++d) {
      const double k = (u[d] - w[d]) / L[d];
      ASSERT_NEAR(k, std::round(k), 1e-9);
      crossed += std::round(k) != 0;
    }
  }
  EXPECT_GT(crossed, 0u) << "no atom crossed the periodic boundary; the unwrapped check is vacuous";
}

TEST_F(LammpsReaderTest, DiameterAndScaledUnwrapped) {
  auto unwrapped = read_all(open_lammps_reader(file("dump.unwrapped.lammpstrj"), frame_opt(-1)));
  auto dia = read_all(open_lammps_reader(file("dump.diameter.lammpstrj"), frame_opt(-1)));
  expect_positions_near(dia, unwrapped, 1e-9);
  ASSERT_TRUE(dia.info.has_radius);
  EXPECT_EQ(dia.all.radius, unwrapped.all.radius);  // radius = diameter / 2
}

TEST_F(LammpsReaderTest, GzipAndZstdWrittenByLammps) {
  for (int64_t f : {0, 2, -1}) {
    SCOPED_TRACE(f);
    auto plain = read_all(open_lammps_reader(file("dump.default.lammpstrj"), frame_opt(f)));
    ASSERT_FALSE(plain.error.has_value()) << plain.error->message;
    for (const char* name : {"dump.lammpstrj.gz", "dump.lammpstrj.zst"}) {
      SCOPED_TRACE(name);
      auto c = read_all(open_lammps_reader(file(name), frame_opt(f)));
      ASSERT_FALSE(c.error.has_value()) << c.error->message;
      EXPECT_EQ(c.info.timestep, plain.info.timestep);
      EXPECT_EQ(c.all.x, plain.all.x);
      EXPECT_EQ(c.all.y, plain.all.y);
      EXPECT_EQ(c.all.z, plain.all.z);
      EXPECT_EQ(c.all.type, plain.all.type);
      EXPECT_EQ(c.all.id, plain.all.id);
    }
  }
}

TEST_F(LammpsReaderTest, CompressionFoundByContentNotExtension) {
  // gzip(1) output under a name without .gz.
  const fs::path out = tmp("gzipped_dump.txt");
  std::string cmd = "gzip -c " + textest::quote(file("dump.xyz.lammpstrj").string()) + " > " +
                    textest::quote(out.string());
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const auto ref = reference("dump.xyz.lammpstrj");
  expect_same_as_reference(read_all(open_lammps_reader(out, frame_opt(3))), ref[3]);
  // zstd written by LAMMPS, renamed.
  fs::copy_file(file("dump.lammpstrj.zst"), tmp("zstd_dump.lammpstrj"), fs::copy_options::overwrite_existing);
  auto z = read_all(open_lammps_reader(tmp("zstd_dump.lammpstrj"), frame_opt(1)));
  auto p = read_all(open_lammps_reader(file("dump.default.lammpstrj"), frame_opt(1)));
  ASSERT_FALSE(z.error.has_value()) << z.error->message;
  EXPECT_EQ(z.all.x, p.all.x);
}

TEST_F(LammpsReaderTest, TriclinicBoxAndScaledCoordinates) {
  const auto ref = reference("tri.xyz.lammpstrj");
  ASSERT_EQ(ref.size(), 3u);
  EXPECT_NE(ref[0].box_flags.find("xy xz yz"), std::string::npos);
  // LAMMPS' own statement of the box: "triclinic box = (xlo ylo zlo) to (xhi yhi zhi) with tilt (xy xz yz)".
  const std::string log = read_text(file("log.lammps"));
  std::smatch m;
  const std::string num = "(-?[0-9.eE+-]+)";
  std::regex re("triclinic box = \\(" + num + " " + num + " " + num + "\\) to \\(" + num + " " + num + " " +
                num + "\\) with tilt \\(" + num + " " + num + " " + num + "\\)");
  ASSERT_TRUE(std::regex_search(log, m, re)) << "no triclinic box line in log.lammps";
  const RefFrame& f0 = ref[0];
  const LammpsBox box = lammps_box_from_bounds(f0.bounds, true);
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(box.lo[d], std::stod(m[1 + d]), 1e-5);
    EXPECT_NEAR(box.hi[d], std::stod(m[4 + d]), 1e-5);
  }
  EXPECT_NEAR(box.xy, std::stod(m[7]), 1e-5);
  EXPECT_NEAR(box.xz, std::stod(m[8]), 1e-5);
  EXPECT_NEAR(box.yz, std::stod(m[9]), 1e-5);

  for (int64_t f : {0, 1, -1}) {
    SCOPED_TRACE(f);
    auto cart = read_all(open_lammps_reader(file("tri.xyz.lammpstrj"), frame_opt(f)));
    expect_same_as_reference(cart, ref[f < 0 ? 2 : static_cast<size_t>(f)]);
    auto scaled = read_all(open_lammps_reader(file("tri.scaled.lammpstrj"), frame_opt(f)));
    expect_positions_near(scaled, cart, 1e-9);
    EXPECT_EQ(scaled.info.box_lo[0], cart.info.box_lo[0]);
    // The cell: origin (xlo, ylo, zlo), a = (lx, 0, 0), b = (xy, ly, 0), c = (xz, yz, lz), periodic
    // (the deck's default boundary p p p); its corners' bounding box is the dump's.
    const SimulationCell& c = cart.info.cell;
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(c.origin[d], std::stod(m[1 + d]), 1e-5);
      EXPECT_NEAR(c.vectors[d][d], std::stod(m[4 + d]) - std::stod(m[1 + d]), 1e-5);
      EXPECT_TRUE(c.periodic[d]);
    }
    EXPECT_NEAR(c.vectors[1][0], std::stod(m[7]), 1e-5);
    EXPECT_NEAR(c.vectors[2][0], std::stod(m[8]), 1e-5);
    EXPECT_NEAR(c.vectors[2][1], std::stod(m[9]), 1e-5);
    EXPECT_EQ(c.vectors[0][1], 0.0);
    EXPECT_EQ(c.vectors[0][2], 0.0);
    EXPECT_EQ(c.vectors[1][2], 0.0);
    double lo[3], hi[3];
    c.bounds(lo, hi);
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(lo[d], cart.info.box_lo[d], 1e-9);
      EXPECT_NEAR(hi[d], cart.info.box_hi[d], 1e-9);
    }
    auto unwrapped = read_all(open_lammps_reader(file("tri.unwrapped.lammpstrj"), frame_opt(f)));
    auto xsu = read_all(open_lammps_reader(file("tri.xsu.lammpstrj"), frame_opt(f)));
    expect_positions_near(xsu, unwrapped, 1e-9);
  }
}

TEST_F(LammpsReaderTest, TypeColumnIsOptional) {
  auto lines = first_frame_lines();
  lines[8] = "ITEM: ATOMS id x y z";
  for (size_t i = 9; i < lines.size(); ++i) {
    std::istringstream is(lines[i]);
    std::string id, type, x, y, z;
    is >> id >> type >> x >> y >> z;
    lines[i] = id + " " + x + " " + y + " " + z;
  }
  auto r = read_all(open_lammps_reader(scratch("notype.lammpstrj", join_lines(lines)), frame_opt(0)));
  ASSERT_FALSE(r.error.has_value()) << r.error->message;
  ASSERT_EQ(r.all.size(), 4000u);
  for (int32_t t : r.all.type) ASSERT_EQ(t, 1);
}

// --- malformed inputs, each derived from real LAMMPS output ---

TEST_F(LammpsReaderTest, TruncatedFile) {
  const std::string text = read_text(file("dump.default.lammpstrj"));
  const auto ref = reference("dump.default.lammpstrj");
  // Cut in the middle of an atom line of the first frame, and at a line boundary.
  for (size_t cut : {text.size() / 12, text.find('\n', text.size() / 14) + 1}) {
    const std::string part = text.substr(0, cut);
    const fs::path p = scratch("truncated.lammpstrj", part);
    const uint64_t line = static_cast<uint64_t>(std::count(part.begin(), part.end(), '\n')) + 1;
    auto r = read_all(open_lammps_reader(p, frame_opt(0)));
    expect_error(r, Errc::format, p, line);
  }
  // Truncated last frame: asking for the last frame fails at open.
  const std::string part = text.substr(0, text.size() - 1000);
  const fs::path p = scratch("truncated_last.lammpstrj", part);
  auto r = read_all(open_lammps_reader(p, frame_opt(-1)));
  expect_error(r, Errc::format, p, static_cast<uint64_t>(std::count(part.begin(), part.end(), '\n')) + 1);
}

TEST_F(LammpsReaderTest, TruncatedCompressedFiles) {
  for (const char* name : {"dump.lammpstrj.gz", "dump.lammpstrj.zst"}) {
    SCOPED_TRACE(name);
    const std::string bytes = read_text(file(name));
    const fs::path p = scratch(std::string("truncated_") + name, bytes.substr(0, bytes.size() / 2));
    auto r = read_all(open_lammps_reader(p, frame_opt(-1)));
    ASSERT_TRUE(r.error.has_value());
    EXPECT_EQ(r.error->code, Errc::format) << r.error->message;
    EXPECT_THAT(r.error->message, HasSubstr(p.string()));
    EXPECT_THAT(r.error->message, HasSubstr("line"));
    EXPECT_THAT(r.error->message, HasSubstr("truncated"));
  }
}

TEST_F(LammpsReaderTest, NonFiniteCoordinates) {
  int k = 0;
  for (const char* bad : {"nan", "inf", "-inf", "NaN", "1e999"}) {
    SCOPED_TRACE(bad);
    auto lines = first_frame_lines();
    const size_t atom = 1234 + 100 * static_cast<size_t>(k++);
    std::istringstream is(lines[9 + atom]);
    std::string id, type, x, y, z;
    is >> id >> type >> x >> y >> z;
    lines[9 + atom] = id + " " + type + " " + x + " " + bad + " " + z;
    const fs::path p = scratch("nonfinite.lammpstrj", join_lines(lines));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::range, p, 10 + atom);
  }
}

// A frame of 64,000 atoms (LAMMPS's 4,000 repeated) is parsed in parallel ranges of ~64 KiB by
// several threads; with two bad lines in different ranges the error names the earlier one,
// whichever range a thread finished first, and the particles of a good copy are the reference's.
TEST_F(LammpsReaderTest, LargeFrameParsedInRangesMatchesAndNamesTheFirstBadLine) {
  const auto base = first_frame_lines();
  const size_t n0 = base.size() - 9, copies = 16, n = n0 * copies;
  std::vector<std::string> lines(base.begin(), base.begin() + 9);
  lines[3] = std::to_string(n);
  for (size_t c = 0; c < copies; ++c) lines.insert(lines.end(), base.begin() + 9, base.end());
  const fs::path good = scratch("large.lammpstrj", join_lines(lines));
  const ReadAll all = read_all(open_lammps_reader(good, frame_opt(0)));
  ASSERT_FALSE(all.error.has_value()) << all.error->message;
  ASSERT_EQ(all.all.size(), n);
  const auto ref = reference("dump.default.lammpstrj");
  for (size_t i = 0; i < n; i += 997) {
    ASSERT_EQ(all.all.id[i], static_cast<int64_t>(ref[0].col(i % n0, "id"))) << i;
    ASSERT_EQ(all.all.x[i], ref[0].col(i % n0, "x")) << i;
    ASSERT_EQ(all.all.z[i], ref[0].col(i % n0, "z")) << i;
  }
  // Atom indices of the two bad lines: far apart (other ranges), the early one a range error
  // (non-finite) or a format error (a missing column), the late one the other kind.
  const struct {
    size_t early, late;
    bool early_nonfinite;
  } cases[] = {{5000, 60000, true}, {30000, 30500, false}, {100, 63999, false}, {41000, 41001, true}};
  for (const auto& c : cases) {
    SCOPED_TRACE(std::to_string(c.early) + " " + std::to_string(c.late));
    auto bad = lines;
    bad[9 + c.early] = c.early_nonfinite ? "1 1 nan 0 0" : "1 1 0.5 0.5";
    bad[9 + c.late] = c.early_nonfinite ? "1 1 0.5 0.5" : "1 1 nan 0 0";
    const fs::path p = scratch("large_bad.lammpstrj", join_lines(bad));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), c.early_nonfinite ? Errc::range : Errc::format, p,
                 10 + c.early);
  }
}

TEST_F(LammpsReaderTest, WrongAtomCount) {
  const std::string text = read_text(file("dump.default.lammpstrj"));
  auto lines = split_lines(text);
  // Too many declared in the first of several frames: the next ITEM: comes early.
  {
    auto l = lines;
    l[3] = "4001";
    const fs::path p = scratch("count_high.lammpstrj", join_lines(l));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::format, p, 9 + 4000 + 1);
    // ... and when the frame is skipped to reach a later one.
    auto r = read_all(open_lammps_reader(p, frame_opt(1)));
    ASSERT_TRUE(r.error.has_value());
    EXPECT_EQ(r.error->code, Errc::format);
    EXPECT_THAT(r.error->message, HasSubstr(p.string() + ":"));
    EXPECT_THAT(r.error->message, HasSubstr("wrong atom count"));
  }
  // Too few declared: an atom line is left over where the next frame should start.
  {
    auto l = lines;
    l[3] = "3999";
    const fs::path p = scratch("count_low.lammpstrj", join_lines(l));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::format, p, 9 + 3999 + 1);
    expect_error(read_all(open_lammps_reader(p, frame_opt(-1))), Errc::format, p, 9 + 3999 + 1);
  }
  // Too many declared in a single-frame file: the file ends early.
  {
    auto l = first_frame_lines();
    l[3] = "4100";
    const fs::path p = scratch("count_single.lammpstrj", join_lines(l));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::format, p, 9 + 4000 + 1);
  }
}

TEST_F(LammpsReaderTest, MissingColumns) {
  // No z column in the header.
  {
    auto l = first_frame_lines();
    l[8] = "ITEM: ATOMS id type x y";
    for (size_t i = 9; i < l.size(); ++i) l[i] = l[i].substr(0, l[i].rfind(' '));
    const fs::path p = scratch("noz.lammpstrj", join_lines(l));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::format, p, 9);
  }
  // One atom line short of a column, one with a column too many.
  for (int extra : {0, 1}) {
    auto l = first_frame_lines();
    const size_t atom = 2500;
    l[9 + atom] = extra ? l[9 + atom] + " 7.5" : l[9 + atom].substr(0, l[9 + atom].rfind(' '));
    const fs::path p = scratch("shortline.lammpstrj", join_lines(l));
    auto r = read_all(open_lammps_reader(p, frame_opt(0)), 1000);
    expect_error(r, Errc::format, p, 10 + atom);
    EXPECT_THAT(r.error->message, HasSubstr(extra ? "found 6" : "found 4"));
  }
  // A type that is not an integer.
  {
    auto l = first_frame_lines();
    l[9 + 17] = "18 1.5 0.1 0.2 0.3";
    const fs::path p = scratch("badtype.lammpstrj", join_lines(l));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::format, p, 9 + 17 + 1);
  }
}

TEST_F(LammpsReaderTest, AbsurdCounts) {
  // 10^18: rejected at the count line, before anything is allocated.
  {
    auto l = first_frame_lines();
    l[3] = "1000000000000000000";
    const fs::path p = scratch("absurd.lammpstrj", join_lines(l));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::range, p, 4);
    // Same in a gzip file.
    const fs::path gz = tmp("absurd.lammpstrj.gz");
    ASSERT_EQ(std::system(("gzip -c " + textest::quote(p.string()) + " > " + textest::quote(gz.string())).c_str()), 0);
    expect_error(read_all(open_lammps_reader(gz, frame_opt(0))), Errc::range, gz, 4);
  }
  // 10^10: plausible on its own, but more than the rest of the file can hold.
  {
    auto l = first_frame_lines();
    l[3] = "10000000000";
    const fs::path p = scratch("toolarge.lammpstrj", join_lines(l));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::range, p, 9);
  }
  // Beyond 64 bits.
  {
    auto l = first_frame_lines();
    l[3] = "100000000000000000000000";
    const fs::path p = scratch("overflow.lammpstrj", join_lines(l));
    expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::range, p, 4);
  }
}

TEST_F(LammpsReaderTest, NotADumpOrEmpty) {
  const fs::path p = scratch("garbage.lammpstrj", "hello world\n1 2 3\n");
  expect_error(read_all(open_lammps_reader(p, frame_opt(0))), Errc::format, p, 1);
  const fs::path e = scratch("empty.lammpstrj", "");
  auto r = read_all(open_lammps_reader(e, frame_opt(0)));
  ASSERT_TRUE(r.error.has_value());
  EXPECT_EQ(r.error->code, Errc::format);
  EXPECT_THAT(r.error->message, HasSubstr(e.string()));
  auto missing = read_all(open_lammps_reader(tmp("does_not_exist.lammpstrj"), frame_opt(0)));
  ASSERT_TRUE(missing.error.has_value());
  EXPECT_EQ(missing.error->code, Errc::io);
}

TEST(LammpsBox, PeriodicityFromTheBoundaryFlags) {
  bool p[3] = {false, false, false};
  lammps_periodic_from_flags({"pp", "fs", "pp"}, p);
  EXPECT_TRUE(p[0]);
  EXPECT_FALSE(p[1]);
  EXPECT_TRUE(p[2]);
  lammps_periodic_from_flags({"xy", "xz", "yz", "fm", "pp", "ff"}, p);  // triclinic: tilt names first
  EXPECT_FALSE(p[0]);
  EXPECT_TRUE(p[1]);
  EXPECT_FALSE(p[2]);
  lammps_periodic_from_flags({}, p);  // an old dump without flags
  EXPECT_FALSE(p[0] || p[1] || p[2]);
}

TEST(LammpsBox, BoundsToBoxFollowsTheManual) {
  // Orthogonal: bounds are the box.
  const double ortho[3][3] = {{-1, 2, 0}, {0, 3, 0}, {5, 6, 0}};
  LammpsBox o = lammps_box_from_bounds(ortho, false);
  EXPECT_EQ(o.lo[0], -1);
  EXPECT_EQ(o.hi[2], 6);
  const double s[3] = {0.5, 0.25, 1.0};
  double c[3];
  o.scaled_to_cartesian(s, c);
  EXPECT_DOUBLE_EQ(c[0], 0.5);
  EXPECT_DOUBLE_EQ(c[1], 0.75);
  EXPECT_DOUBLE_EQ(c[2], 6.0);
}

// list_frames on LAMMPS' own multi-frame dumps (plain and zstd): the five steps it wrote, each
// with its atom count, and every frame opened at its mark equals the frame opened by index.
TEST_F(LammpsReaderTest, ListFramesOfRealDumps) {
  const auto ref = reference("dump.xyz.lammpstrj");
  const auto ref_default = reference("dump.default.lammpstrj");  // what dump custom/zstd wrote, uncompressed
  ASSERT_EQ(ref.size(), 5u);
  ASSERT_EQ(ref_default.size(), 5u);
  for (const char* name : {"dump.xyz.lammpstrj", "dump.lammpstrj.zst"}) {
    SCOPED_TRACE(name);
    const bool plain = std::string(name) == "dump.xyz.lammpstrj";
    auto frames = list_frames(file(name), {});
    ASSERT_TRUE(frames.ok()) << frames.error().message;
    ASSERT_EQ(frames->size(), ref.size());
    for (size_t k = 0; k < ref.size(); ++k) {
      const FrameEntry& e = (*frames)[k];
      EXPECT_EQ(e.timestep, ref[k].timestep);
      EXPECT_EQ(e.particle_count, ref[k].natoms);
      ReaderOptions o = frame_opt(int64_t(k));
      o.start = e.mark;
      auto r = read_all(open_lammps_reader(file(name), o));
      expect_same_as_reference(r, plain ? ref[k] : ref_default[k]);
    }
  }
  // A mark is used only for the frame it names: frame 2 with frame 1's mark skips as before.
  auto frames = list_frames(file("dump.xyz.lammpstrj"), {});
  ASSERT_TRUE(frames.ok());
  ReaderOptions o = frame_opt(2);
  o.start = (*frames)[1].mark;
  expect_same_as_reference(read_all(open_lammps_reader(file("dump.xyz.lammpstrj"), o)), ref[2]);
}

// The relay (ReaderOptions::relay) hands the zstd file's source from frame to frame: a reader
// takes it, gives it back when destroyed, and the frames read through it equal those read alone.
TEST_F(LammpsReaderTest, RelayPassesTheSourceFromFrameToFrame) {
  const fs::path zst = file("dump.lammpstrj.zst");
  const auto ref = reference("dump.default.lammpstrj");
  auto frames = list_frames(zst, {});
  ASSERT_TRUE(frames.ok()) << frames.error().message;
  auto relay = std::make_shared<TextSourceRelay>();
  for (int64_t k : {1, 2, 4}) {
    SCOPED_TRACE(k);
    ReaderOptions o = frame_opt(k);
    o.start = (*frames)[size_t(k)].mark;
    o.relay = relay;
    const bool had = relay->source != nullptr;
    EXPECT_EQ(had, k != 1);
    auto r = open_lammps_reader(zst, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(relay->source, nullptr) << "the reader did not take the source";
    auto all = read_all(std::move(r));
    expect_same_as_reference(all, ref[size_t(k)]);
    EXPECT_NE(relay->source, nullptr) << "the reader did not give the source back";
  }
  // A source of another file is not taken.
  ReaderOptions o = frame_opt(0);
  o.start = (*frames)[0].mark;
  o.relay = relay;
  auto other = list_frames(file("dump.xyz.lammpstrj"), {});
  ASSERT_TRUE(other.ok());
  o.start = (*other)[0].mark;
  auto r = open_lammps_reader(file("dump.xyz.lammpstrj"), o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_NE(relay->source, nullptr);
}

}  // namespace
}  // namespace mds
