// The simulation cell (core/cell.h) through the store: the cell section's bytes (golden offsets),
// its round trip, corrupted and truncated cell sections, the writer's preconditions, and the
// command line: a LAMMPS dump's box kept by convert, reported by info, written back by export as
// extended XYZ's Lattice/Origin/pbc and read again to the same bits; inputs whose cells differ.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "scoped_temp_dir.h"
#include "store/hash.h"
#include "store/section_codec.h"
#include "store/store_reader.h"
#include "store_test_helpers.h"

namespace mds {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::run_mdstream;

SimulationCell triclinic() {
  SimulationCell c;
  const double o[3] = {-1.25, 0.5, 3.0};
  const double v[3][3] = {{10.0, 0.0, 0.0}, {2.5, 9.0, 0.0}, {-1.5, 0.75, 8.0}};
  for (int d = 0; d < 3; ++d) {
    c.origin[d] = o[d];
    for (int k = 0; k < 3; ++k) c.vectors[d][k] = v[d][k];
  }
  c.periodic[0] = true;
  c.periodic[2] = true;
  return c;
}

TEST(SimulationCell, CornersEdgesAndBounds) {
  const SimulationCell c = triclinic();
  // Every edge joins two corners that differ along exactly one vector.
  int along[3] = {0, 0, 0};
  for (const auto& e : SimulationCell::edges()) {
    const int diff = e[0] ^ e[1];
    ASSERT_TRUE(diff == 1 || diff == 2 || diff == 4) << e[0] << "-" << e[1];
    ++along[diff == 1 ? 0 : diff == 2 ? 1 : 2];
  }
  EXPECT_EQ(along[0], 4);
  EXPECT_EQ(along[1], 4);
  EXPECT_EQ(along[2], 4);
  const auto far = c.corner(7);  // origin + a + b + c
  EXPECT_DOUBLE_EQ(far[0], -1.25 + 10.0 + 2.5 - 1.5);
  EXPECT_DOUBLE_EQ(far[1], 0.5 + 9.0 + 0.75);
  EXPECT_DOUBLE_EQ(far[2], 3.0 + 8.0);
  double lo[3], hi[3];
  c.bounds(lo, hi);
  EXPECT_DOUBLE_EQ(lo[0], -1.25 - 1.5);  // origin + c
  EXPECT_DOUBLE_EQ(hi[0], -1.25 + 10.0 + 2.5);  // origin + a + b
  EXPECT_DOUBLE_EQ(lo[1], 0.5);
  EXPECT_DOUBLE_EQ(hi[1], 0.5 + 9.75);
  EXPECT_FALSE(c.orthogonal());
  const double blo[3] = {0, 1, 2}, bhi[3] = {3, 5, 7};
  EXPECT_TRUE(SimulationCell::box(blo, bhi).orthogonal());
  EXPECT_EQ(SimulationCell::box(blo, bhi).vectors[2][2], 5.0);
}

class CellStore : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::temp_dir("cell", /*in_memory=*/true);
    testing::SynthOptions o;
    o.particles = 60;
    o.node_size = 30;
    o.meshlet_size = 8;
    store_ = testing::make_synthetic(o);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::optional<SimulationCell>& cell, const std::string& name = "c.mds") {
    store_.summary.cell = cell;
    const fs::path p = dir_ / name;
    EXPECT_EQ(testing::write_store(store_, p), "");
    return p;
  }
  // Opens `bytes` as a store; the error message, or "" when it opens.
  std::string open_error(const std::vector<uint8_t>& bytes) {
    const fs::path p = dir_ / "bad.mds";
    testing::write_bytes(p, bytes);
    auto r = store::StoreReader::open(p);
    return r.ok() ? std::string() : r.error().message;
  }
  static store::FileHeader header(const std::vector<uint8_t>& b) {
    store::FileHeader h;
    std::memcpy(&h, b.data(), sizeof(h));
    return h;
  }
  // Puts `h` back with its hash recomputed.
  static void reseal(std::vector<uint8_t>& b, store::FileHeader h) {
    h.header_hash = 0;
    h.header_hash = store::hash_bytes({reinterpret_cast<const uint8_t*>(&h), sizeof(h)});
    std::memcpy(b.data(), &h, sizeof(h));
  }

  fs::path dir_;
  testing::SynthStore store_;
};

TEST_F(CellStore, TheCellSectionEndsTheFileAndRoundTrips) {
  const SimulationCell c = triclinic();
  const fs::path p = write(c);
  const std::vector<uint8_t> b = testing::read_bytes(p);
  const store::FileHeader h = header(b);
  EXPECT_TRUE(h.flags & store::kFlagCell);
  // Golden layout: the header's entry at byte 416, the 128-byte record after the occupancy
  // section, at the end of the file.
  EXPECT_EQ(offsetof(store::FileHeader, cell), 416u);
  const uint64_t occ_end = h.sections[store::kSectionOccupancy].offset + h.sections[store::kSectionOccupancy].bytes;
  EXPECT_EQ(h.cell.offset, occ_end);
  EXPECT_EQ(h.cell.bytes, 128u);
  EXPECT_EQ(h.cell.raw_bytes, 128u);
  ASSERT_EQ(b.size(), occ_end + 128);
  const uint8_t* rec = b.data() + occ_end;
  EXPECT_EQ(h.cell.hash, store::hash_bytes({rec, 128}));
  double v;
  std::memcpy(&v, rec + 0, 8);  // origin[0]
  EXPECT_EQ(v, -1.25);
  std::memcpy(&v, rec + 24 + 8 * (3 * 2 + 1), 8);  // vectors[2][1] (c.y)
  EXPECT_EQ(v, 0.75);
  uint32_t periodic;
  std::memcpy(&periodic, rec + 96, 4);
  EXPECT_EQ(periodic, 0b101u);
  for (int i = 100; i < 128; ++i) EXPECT_EQ(rec[i], 0) << i;

  auto r = store::StoreReader::open(p);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE((*r)->cell().has_value());
  EXPECT_TRUE(*(*r)->cell() == c);

  // Without a cell: no flag, the entry all zero, the file as before.
  const fs::path q = write(std::nullopt, "none.mds");
  const std::vector<uint8_t> nb = testing::read_bytes(q);
  const store::FileHeader nh = header(nb);
  EXPECT_FALSE(nh.flags & store::kFlagCell);
  EXPECT_EQ(nh.cell.offset, 0u);
  EXPECT_EQ(nh.cell.hash, 0u);
  EXPECT_EQ(nb.size(), b.size() - 128);
  auto nr = store::StoreReader::open(q);
  ASSERT_TRUE(nr.ok()) << nr.error().message;
  EXPECT_FALSE((*nr)->cell().has_value());
}

TEST_F(CellStore, CorruptedAndTruncatedCellSectionsAreNamed) {
  const std::vector<uint8_t> good = testing::read_bytes(write(triclinic()));
  const store::FileHeader h = header(good);
  const uint64_t at = h.cell.offset;
  {  // a flipped bit in the record
    auto b = good;
    b[at + 30] ^= 0x10;
    EXPECT_THAT(open_error(b), HasSubstr("cell section at byte " + std::to_string(at) + ": checksum mismatch"));
  }
  {  // a NaN origin with a matching hash: the record's field and byte
    auto b = good;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::memcpy(b.data() + at + 8, &nan, 8);
    store::FileHeader hh = h;
    hh.cell.hash = store::hash_bytes({b.data() + at, 128});
    reseal(b, hh);
    EXPECT_THAT(open_error(b), HasSubstr("origin[1] at byte 8 of the record is not finite"));
  }
  {  // an unknown periodic bit
    auto b = good;
    b[at + 96] |= 0x08;
    store::FileHeader hh = h;
    hh.cell.hash = store::hash_bytes({b.data() + at, 128});
    reseal(b, hh);
    EXPECT_THAT(open_error(b), HasSubstr("periodic at byte 96 of the record has unknown bits 0x8"));
  }
  for (size_t cut : {1, 64, 128}) {  // truncated
    SCOPED_TRACE(cut);
    auto b = good;
    b.resize(b.size() - cut);
    const std::string e = open_error(b);
    EXPECT_THAT(e, HasSubstr("field cell.bytes at byte 424"));
    EXPECT_THAT(e, HasSubstr("runs past the end"));
  }
  {  // a reserved word of the record set
    auto b = good;
    b[at + 100 + 8] = 1;
    store::FileHeader hh = h;
    hh.cell.hash = store::hash_bytes({b.data() + at, 128});
    reseal(b, hh);
    EXPECT_THAT(open_error(b), HasSubstr("reserved at byte 108 of the record is not zero"));
  }
  {  // a value beyond float range (a renderer could not draw it)
    auto b = good;
    const double huge = 1e300;
    std::memcpy(b.data() + at + 24, &huge, 8);
    store::FileHeader hh = h;
    hh.cell.hash = store::hash_bytes({b.data() + at, 128});
    reseal(b, hh);
    EXPECT_THAT(open_error(b), HasSubstr("vectors[0][0] at byte 24 of the record is 1e+300, beyond"));
  }
  {  // the flag without the section
    auto b = good;
    b.resize(b.size() - 128);
    store::FileHeader hh = h;
    hh.cell = {};
    reseal(b, hh);
    EXPECT_THAT(open_error(b), HasSubstr("field cell.offset at byte 416: cell section at byte 0, expected"));
  }
  {  // a wrong size in the header
    auto b = good;
    store::FileHeader hh = h;
    hh.cell.bytes = hh.cell.raw_bytes = 96;
    reseal(b, hh);
    EXPECT_THAT(open_error(b), HasSubstr("field cell.bytes at byte 424: cell section has 96 bytes"));
  }
  {  // the section present but the flag cleared: bytes after the last section
    auto b = good;
    store::FileHeader hh = h;
    hh.flags &= ~uint32_t(store::kFlagCell);
    hh.cell = {};
    reseal(b, hh);
    EXPECT_THAT(open_error(b), HasSubstr("128 bytes after the last section"));
  }
}

TEST_F(CellStore, TheWriterRefusesANonFiniteCell) {
  SimulationCell c = triclinic();
  c.vectors[1][2] = std::numeric_limits<double>::infinity();
  store_.summary.cell = c;
  EXPECT_THAT(testing::write_store(store_, dir_ / "inf.mds"), HasSubstr("cell with a non-finite value"));
  store_.summary.cell.reset();
  store_.summary.flags |= store::kFlagCell;
  EXPECT_THAT(testing::write_store(store_, dir_ / "flag.mds"), HasSubstr("kFlagCell without a cell"));
  EXPECT_FALSE(fs::exists(dir_ / "inf.mds"));
}

// ---------------------------------------------------------------- the command line

nlohmann::json info_json(const fs::path& store) {
  const fs::path out = store.string() + ".json";
  EXPECT_EQ(run_mdstream("info --json " + store.string() + " > " + out.string()), 0) << cli_stderr();
  std::ifstream f(out);
  return nlohmann::json::parse(f);
}

TEST(CellCli, ConvertKeepsTheBoxInfoReportsItExportWritesItBack) {
  test::ScopedTempDir tmp("mds_cell_");
  const fs::path dump = tmp.p / "t.lammpstrj";
  {  // a triclinic LAMMPS box (bounding box and tilts), periodic in x and z
    std::ofstream f(dump);
    f << "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n3\nITEM: BOX BOUNDS xy xz yz pp fs pp\n"
         "-1.5 12.5 2.0\n0 9 -0.5\n1 7 -0.5\nITEM: ATOMS id type x y z\n"
         "1 1 1 1 2\n2 2 5 4 3\n3 1 9 8 6\n";
  }
  // LAMMPS' restricted box (xy = 2, xz = -0.5, yz = -0.5): xlo = -1.5 - min(0, 2, -0.5, 1.5) = -1,
  // xhi = 12.5 - max(0, 2, -0.5, 1.5) = 10.5; ylo = 0 - min(0, -0.5) = 0.5, yhi = 9 - 0 = 9;
  // a = (11.5, 0, 0), b = (2, 8.5, 0), c = (-0.5, -0.5, 6).
  const fs::path mds = tmp.p / "t.mds";
  ASSERT_EQ(run_mdstream("convert -q " + dump.string() + " -o " + mds.string()), 0) << cli_stderr();
  const nlohmann::json cell = info_json(mds)["cell"];
  ASSERT_FALSE(cell.is_null());
  EXPECT_EQ(cell["origin"], nlohmann::json::parse("[-1.0, 0.5, 1.0]"));
  EXPECT_EQ(cell["vectors"], nlohmann::json::parse("[[11.5, 0.0, 0.0], [2.0, 8.5, 0.0], [-0.5, -0.5, 6.0]]"));
  EXPECT_EQ(cell["periodic"], nlohmann::json::parse("[true, false, true]"));
  EXPECT_EQ(cell["orthogonal"], false);

  // export -> extended XYZ with Lattice/Origin/pbc -> convert: the same cell, bit for bit.
  const fs::path xyz = tmp.p / "t.xyz";
  ASSERT_EQ(run_mdstream("export " + mds.string() + " -o " + xyz.string()), 0) << cli_stderr();
  std::ifstream f(xyz);
  std::string line;
  std::getline(f, line);
  std::getline(f, line);
  EXPECT_THAT(line, HasSubstr("Lattice=\"11.5 0 0 2 8.5 0 -0.5 -0.5 6\" Origin=\"-1 0.5 1\" pbc=\"T F T\""));
  const fs::path back = tmp.p / "back.mds";
  ASSERT_EQ(run_mdstream("convert -q " + xyz.string() + " -o " + back.string()), 0) << cli_stderr();
  EXPECT_EQ(info_json(back)["cell"], cell);

  // The text summary names it.
  ASSERT_EQ(run_mdstream("info " + mds.string() + " > " + (tmp.p / "info.txt").string()), 0);
  std::ifstream t(tmp.p / "info.txt");
  std::stringstream ss;
  ss << t.rdbuf();
  EXPECT_THAT(ss.str(), HasSubstr("cell             triclinic a (11.5, 0, 0) b (2, 8.5, 0) c (-0.5, -0.5, 6) at (-1, 0.5, 1), "
                                  "periodic along a c"));
}

TEST(CellCli, InputsWithDifferentCellsKeepNone) {
  test::ScopedTempDir tmp("mds_cell_");
  auto dump = [&](const std::string& name, double hi) {
    const fs::path p = tmp.p / name;
    std::ofstream f(p);
    f << "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp pp\n0 " << hi << "\n0 4\n0 4\n"
      << "ITEM: ATOMS id type x y z\n1 1 1 1 1\n2 1 2 2 2\n";
    return p.string();
  };
  const std::string a = dump("a.lammpstrj", 4), b = dump("b.lammpstrj", 5), c = dump("c.lammpstrj", 4);
  const fs::path same = tmp.p / "same.mds", differ = tmp.p / "differ.mds";
  ASSERT_EQ(run_mdstream("convert -q " + a + " " + c + " -o " + same.string()), 0) << cli_stderr();
  EXPECT_FALSE(info_json(same)["cell"].is_null());
  ASSERT_EQ(run_mdstream("convert " + a + " " + b + " -o " + differ.string()), 0) << cli_stderr();
  EXPECT_THAT(cli_stderr(), HasSubstr("none kept: the inputs' cells differ"));
  EXPECT_TRUE(info_json(differ)["cell"].is_null());
}

}  // namespace
}  // namespace mds
