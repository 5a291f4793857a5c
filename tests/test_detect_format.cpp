// detect_format / open_reader: every format recognised by content (misleading
// extensions included), gzip/zstd-compressed text, HDF5 without /h5md, raw only by
// request or extension, unknown content rejected with the file name. LAMMPS output
// comes from a real `lmp` run; H5MD from h5py; MMPLD from tests/tools/write_mmpld.py.
#include <gtest/gtest.h>
#include <zlib.h>
#include <zstd.h>

#include "binreader_test_util.h"
#include "h5md/h5md_reader.h"
#include "readers/mmpld_reader.h"
#include "readers/reader_factories.h"

namespace mds {
namespace {

using testing::TempDir;

constexpr const char* kLammpsInput = R"(units lj
atom_style atomic
lattice fcc 0.8442
region box block 0 3 0 3 0 3
create_box 2 box
create_atoms 1 box
mass * 1.0
velocity all create 1.0 87287 loop geom
pair_style lj/cut 2.5
pair_coeff * * 1.0 1.0 2.5
fix 1 all nve
dump d all atom 5 dump.looks_like.xyz
dump x all xyz 5 traj.dat
run 10
)";

constexpr const char* kH5py = R"PY(
import sys, numpy as np, h5py
d = sys.argv[1]
for name, ub in (("h5md.bin", 0), ("userblock.h5md", 512)):
    with h5py.File(d + "/" + name, "w", userblock_size=ub) as f:
        f.create_group("h5md").attrs["version"] = np.array([1, 1])
        f.create_group("particles/all/position")["value"] = np.arange(2 * 4 * 3, dtype=np.float32).reshape(2, 4, 3)
with h5py.File(d + "/plain.h5md", "w") as f:
    f["particles/all/position/value"] = np.zeros((1, 2, 3))
)PY";

std::string file_text(const std::filesystem::path& p) {
  auto b = testing::read_bytes(p);
  return std::string(b.begin(), b.end());
}

void write_gzip(const std::filesystem::path& p, const std::string& text) {
  gzFile gz = gzopen(p.c_str(), "wb");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
  gzclose(gz);
}

void write_zstd(const std::filesystem::path& p, const std::string& text) {
  std::string out(ZSTD_compressBound(text.size()), '\0');
  size_t n = ZSTD_compress(out.data(), out.size(), text.data(), text.size(), 3);
  ASSERT_FALSE(ZSTD_isError(n));
  testing::write_bytes(p, out.data(), n);
}

class DetectFormat : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    testing::write_text(*dir_ / "in.lmp", kLammpsInput);
    const std::string cmd = "cd '" + dir_->path().string() + "' && lmp -in in.lmp -log none -screen none";
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    testing::write_text(*dir_ / "h5.py", kH5py);
    ASSERT_EQ(testing::run_python({(*dir_ / "h5.py").string(), dir_->path().string()}), 0);
    testing::write_text(*dir_ / "mmpld.json",
                        R"({"version":102,"seed":4,"frames":[{"lists":[{"vertex":1,"colour":0,"count":12,"radius":0.5}]}]})");
    ASSERT_EQ(testing::run_python({testing::source_path("tests/tools/write_mmpld.py"), (*dir_ / "mmpld.json").string(),
                                   (*dir_ / "particles.dat").string(), (*dir_ / "mmpld.expected.json").string()}),
              0);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::filesystem::path p(const std::string& name) { return *dir_ / name; }
  static TempDir* dir_;
};
TempDir* DetectFormat::dir_ = nullptr;

InputFormat detect_ok(const std::filesystem::path& path) {
  auto r = detect_format(path);
  EXPECT_TRUE(r.ok()) << r.error().message;
  return r.ok() ? *r : InputFormat::automatic;
}

TEST_F(DetectFormat, LammpsDumpWithMisleadingExtension) {
  ASSERT_EQ(file_text(p("dump.looks_like.xyz")).rfind("ITEM: TIMESTEP", 0), 0u);
  EXPECT_EQ(detect_ok(p("dump.looks_like.xyz")), InputFormat::lammps);
}

TEST_F(DetectFormat, CompressedLammpsAndXyz) {
  write_gzip(p("dump.lammpstrj.gz"), file_text(p("dump.looks_like.xyz")));
  write_gzip(p("noext"), file_text(p("dump.looks_like.xyz")));
  write_zstd(p("dump.zst"), file_text(p("dump.looks_like.xyz")));
  write_gzip(p("traj.xyz.gz"), file_text(p("traj.dat")));
  write_zstd(p("traj.mmpld"), file_text(p("traj.dat")));  // misleading extension again
  EXPECT_EQ(detect_ok(p("dump.lammpstrj.gz")), InputFormat::lammps);
  EXPECT_EQ(detect_ok(p("noext")), InputFormat::lammps);
  EXPECT_EQ(detect_ok(p("dump.zst")), InputFormat::lammps);
  EXPECT_EQ(detect_ok(p("traj.xyz.gz")), InputFormat::xyz);
  EXPECT_EQ(detect_ok(p("traj.mmpld")), InputFormat::xyz);
  write_gzip(p("garbage.gz"), std::string("\x01\x02\x03 binary junk", 15));
  auto g = detect_format(p("garbage.gz"));
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().message.find("garbage.gz"), std::string::npos);
  EXPECT_NE(g.error().message.find("gzip"), std::string::npos);
}

TEST_F(DetectFormat, XyzFromLammps) {
  const std::string t = file_text(p("traj.dat"));
  ASSERT_EQ(t.substr(0, 4), "108\n");
  EXPECT_EQ(detect_ok(p("traj.dat")), InputFormat::xyz);
}

TEST_F(DetectFormat, H5mdAndPlainHdf5) {
  EXPECT_EQ(detect_ok(p("h5md.bin")), InputFormat::h5md);
  EXPECT_EQ(detect_ok(p("userblock.h5md")), InputFormat::h5md);
  auto r = detect_format(p("plain.h5md"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::format);
  EXPECT_NE(r.error().message.find("HDF5 file without /h5md group"), std::string::npos);
  EXPECT_NE(r.error().message.find("plain.h5md"), std::string::npos);
}

TEST_F(DetectFormat, MmpldByMagic) { EXPECT_EQ(detect_ok(p("particles.dat")), InputFormat::mmpld); }

TEST_F(DetectFormat, RawOnlyByExtensionOrRequest) {
  const float xyz[6] = {1.5f, 2.5f, 3.5f, -1.0f, 0.0f, 7.0f};
  for (const char* name : {"pts.raw", "pts.F32", "pts.bin"}) testing::write_bytes(p(name), xyz, sizeof(xyz));
  EXPECT_EQ(detect_ok(p("pts.raw")), InputFormat::raw);
  EXPECT_EQ(detect_ok(p("pts.F32")), InputFormat::raw);
  auto r = detect_format(p("pts.bin"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::format);
  EXPECT_NE(r.error().message.find("pts.bin"), std::string::npos);
  ReaderOptions o;
  o.format = InputFormat::raw;
  auto reader = open_reader(p("pts.bin"), o);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  EXPECT_EQ((*reader)->info().particle_count, 2u);
}

TEST_F(DetectFormat, UnknownEmptyMissing) {
  testing::write_text(p("notes.txt"), "hello world\nthis is not particle data\n");
  testing::write_text(p("empty.xyz"), "");
  testing::write_text(p("countonly.bin"), std::string("12\n\x01\x02\x03\x00\x05", 8));
  for (const char* name : {"notes.txt", "empty.xyz", "missing.lammpstrj", "countonly.bin"}) {
    auto r = detect_format(p(name));
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_NE(r.error().message.find(name), std::string::npos) << r.error().message;
  }
  EXPECT_EQ(detect_format(p("notes.txt")).error().code, Errc::format);
  EXPECT_EQ(detect_format(p("missing.lammpstrj")).error().code, Errc::io);
}

TEST_F(DetectFormat, OpenReaderDispatchesBinaryFormats) {
  auto m = open_reader(p("particles.dat"), {});
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_NE(dynamic_cast<MmpldReader*>(m->get()), nullptr);
  EXPECT_EQ((*m)->info().particle_count, 12u);
  ReaderOptions last;
  last.frame = -1;
  auto h = open_reader(p("h5md.bin"), last);
  ASSERT_TRUE(h.ok()) << h.error().message;
  EXPECT_NE(dynamic_cast<H5mdReader*>(h->get()), nullptr);
  EXPECT_EQ(dynamic_cast<H5mdReader*>(h->get())->frame_index(), 1u);
  auto bad = open_reader(p("plain.h5md"), {});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("without /h5md"), std::string::npos);
}

// Integration with the text readers (written by another helper): the detected LAMMPS
// dump opens with the declared atom count.
TEST_F(DetectFormat, OpenReaderDispatchesLammps) {
  auto r = open_reader(p("dump.looks_like.xyz"), {});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ((*r)->info().particle_count, 108u);
}

}  // namespace
}  // namespace mds
