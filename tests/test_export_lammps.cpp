// `mdstream export STORE -o OUT.lammpstrj` and `-o OUT.data` (cli/export_lammps.cpp): a LAMMPS
// text dump and data file. LAMMPS itself reads them (read_dump into a box of the dump's, or
// read_data; write_dump back: the same box to the bit, every atom at its position up to LAMMPS'
// wrapping into the periodic box), orthogonal and triclinic, atomic and sphere (diameters); mdstream's own reader reads it back as the extended XYZ export's particles with the
// store's cell, radii and property; types from input ids or names (the element column); slices
// and a threshold; and a cell LAMMPS cannot hold is refused, leaving no file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "binreader_test_util.h"
#include "cli_test_util.h"
#include "readers/lammps_reader.h"
#include "readers/reader_factories.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::run_mdstream;
using testing::TempDir;

struct Atom {
  int type = 0;
  double x[3] = {0, 0, 0};
  std::vector<std::string> rest;  // the columns after z
};

// A one-frame dump as text: its header lines up to ITEM: ATOMS, that line, and the atoms by id.
struct Dump {
  std::vector<std::string> header;
  std::string atoms_line;
  double bound[3][3] = {};  // lo_bound, hi_bound, tilt per line
  std::map<long, Atom> atoms;
};

Dump read_dump_text(const fs::path& p) {
  Dump d;
  std::ifstream f(p);
  std::string line;
  int box_line = -1;
  while (std::getline(f, line)) {
    if (line.rfind("ITEM: ATOMS", 0) == 0) {
      d.atoms_line = line;
      break;
    }
    d.header.push_back(line);
    if (line.rfind("ITEM: BOX BOUNDS", 0) == 0) {
      box_line = 0;
      continue;
    }
    if (box_line >= 0 && box_line < 3) {
      std::istringstream s(line);
      s >> d.bound[box_line][0] >> d.bound[box_line][1] >> d.bound[box_line][2];
      ++box_line;
    }
  }
  while (std::getline(f, line)) {
    std::istringstream s(line);
    long id;
    Atom a;
    s >> id >> a.type >> a.x[0] >> a.x[1] >> a.x[2];
    for (std::string t; s >> t;) a.rest.push_back(t);
    d.atoms[id] = a;
  }
  return d;
}

// Runs lmp on `deck` (written into dir) there; true when it succeeded.
bool run_lmp(const fs::path& dir, const std::string& deck) {
  textest::write_text(dir / "in.readback", deck);
  const std::string cmd = "cd '" + dir.string() + "' && lmp -in in.readback -log none -screen none";
  return std::system(cmd.c_str()) == 0;
}

// LAMMPS reads the export back: the same box, to the bit, and every atom where the export put it
// up to whole periods of the box (read_dump wraps atoms into a periodic box).
// `back` (LAMMPS' write_dump) against our dump of the same atoms: the same box, and every atom
// where ours put it up to whole periods of the box.
void expect_same_atoms(const Dump& ours, const Dump& back, size_t count) {
  ASSERT_EQ(ours.atoms.size(), count);
  ASSERT_EQ(back.atoms.size(), count);
  EXPECT_EQ(ours.header[4], back.header[4]) << "ITEM: BOX BOUNDS flags";
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(ours.bound[i][k], back.bound[i][k]) << i << "," << k;
  // Edge vectors of the box from the bounds (readers/lammps_reader.h), for the periods.
  const double xy = ours.bound[0][2], xz = ours.bound[1][2], yz = ours.bound[2][2];
  const double lx = (ours.bound[0][1] - std::max({0.0, xy, xz, xy + xz})) - (ours.bound[0][0] - std::min({0.0, xy, xz, xy + xz}));
  const double ly = (ours.bound[1][1] - std::max(0.0, yz)) - (ours.bound[1][0] - std::min(0.0, yz));
  const double lz = ours.bound[2][1] - ours.bound[2][0];
  size_t wrapped = 0;
  for (const auto& [id, a] : ours.atoms) {
    const auto it = back.atoms.find(id);
    ASSERT_NE(it, back.atoms.end()) << id;
    EXPECT_EQ(it->second.type, a.type) << id;
    // The difference in fractional coordinates of the box (upper triangular: z, then y, then x).
    const double dz = (it->second.x[2] - a.x[2]) / lz;
    const double dy = (it->second.x[1] - a.x[1] - dz * yz) / ly;
    const double dx = (it->second.x[0] - a.x[0] - dz * xz - dy * xy) / lx;
    for (const double f : {dx, dy, dz}) EXPECT_NEAR(f, std::round(f), 1e-12) << id;
    wrapped += std::round(dx) != 0 || std::round(dy) != 0 || std::round(dz) != 0;
  }
  EXPECT_LT(wrapped, count / 10);
}

void expect_lammps_reads(const fs::path& dir, const fs::path& dump, const std::string& region, size_t count) {
  const std::string deck = fmt::format(
      "units lj\natom_style atomic\nregion box {}\ncreate_box 2 box\nmass * 1.0\n"
      "read_dump {} 0 x y z box yes add keep\n"
      "write_dump all custom back.dump id type x y z modify sort id format float %.17g\n",
      region, dump.string());
  ASSERT_TRUE(run_lmp(dir, deck)) << "lmp could not read " << dump;
  expect_same_atoms(read_dump_text(dump), read_dump_text(dir / "back.dump"), count);
}

// LAMMPS' read_data takes our data file: the atoms and box of our dump of the same store.
void expect_read_data_matches(const fs::path& dir, const fs::path& data, const fs::path& dump, size_t count) {
  const std::string deck = fmt::format(
      "units lj\natom_style atomic\nboundary p p p\nread_data {}\nmass * 1.0\n"
      "write_dump all custom back_data.dump id type x y z modify sort id format float %.17g\n",
      data.string());
  ASSERT_TRUE(run_lmp(dir, deck)) << "lmp could not read " << data;
  expect_same_atoms(read_dump_text(dump), read_dump_text(dir / "back_data.dump"), count);
}

// lammps_box_from_cell undoes LammpsBox::cell: a cell, its dump bounds, and the box read from
// them give the cell back (to rounding); cells LAMMPS cannot hold are refused by name.
TEST(ExportLammps, TheBoxOfACellIsTheInverseOfTheReaders) {
  const double tilts[][3] = {{0, 0, 0}, {2.0, -1.5, 1.0}, {-3.25, 0.5, -0.75}, {1e-3, 0, 0}};
  for (const auto& t : tilts) {
    SimulationCell c;
    const double o[3] = {-4.5, 0.25, 10.0}, len[3] = {8.0, 7.0, 6.5};
    for (int d = 0; d < 3; ++d) {
      c.origin[d] = o[d];
      c.vectors[d][d] = len[d];
      c.periodic[d] = d != 1;
    }
    c.vectors[1][0] = t[0];
    c.vectors[2][0] = t[1];
    c.vectors[2][1] = t[2];
    auto b = lammps_box_from_cell(c);
    ASSERT_TRUE(b.ok()) << b.error().message;
    EXPECT_EQ(b->triclinic, t[0] != 0 || t[1] != 0 || t[2] != 0);
    const double bounds[3][3] = {{b->bound_lo[0], b->bound_hi[0], t[0]},
                                 {b->bound_lo[1], b->bound_hi[1], t[1]},
                                 {b->bound_lo[2], b->bound_hi[2], t[2]}};
    const SimulationCell back = lammps_box_from_bounds(bounds, b->triclinic).cell(c.periodic);
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(back.origin[d], c.origin[d], 1e-14 * 16);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(back.vectors[d][k], c.vectors[d][k], 1e-14 * 16) << d << "," << k;
    }
  }
  SimulationCell rotated;
  rotated.vectors[0][1] = 10.0;
  rotated.vectors[1][0] = -10.0;
  rotated.vectors[2][2] = 10.0;
  SimulationCell flat = SimulationCell::box(std::array<double, 3>{0, 0, 0}.data(), std::array<double, 3>{1, 1, 0}.data());
  SimulationCell left_handed = SimulationCell::box(std::array<double, 3>{0, 0, 0}.data(), std::array<double, 3>{1, 1, 1}.data());
  left_handed.vectors[2][2] = -1.0;
  for (const SimulationCell& c : {rotated, flat, left_handed}) {
    auto b = lammps_box_from_cell(c);
    ASSERT_FALSE(b.ok());
    EXPECT_EQ(b.error().code, Errc::unsupported);
    EXPECT_THAT(b.error().message, HasSubstr("are not a LAMMPS box"));
  }
}

// LAMMPS reads the dump (read_dump) and the data file (read_data) back, orthogonal and triclinic.
TEST(ExportLammps, LammpsReadsAnOrthogonalAndATriclinicBox) {
  TempDir dir;
  const fs::path lj = textest::cached_lammps_run("in.lj_small");
  const fs::path tri = textest::cached_lammps_run("in.triclinic_small");
  ASSERT_FALSE(lj.empty());
  ASSERT_FALSE(tri.empty());
  ASSERT_EQ(run_mdstream("convert -q --frame 2 " + (lj / "dump.xyz.lammpstrj").string() + " -o " + (dir / "lj.mds").string()), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + (dir / "lj.mds").string() + " -o " + (dir / "lj.lammpstrj").string()), 0)
      << cli_stderr();
  const Dump lj_dump = read_dump_text(dir / "lj.lammpstrj");
  EXPECT_EQ(lj_dump.header[4], "ITEM: BOX BOUNDS pp pp pp");
  EXPECT_EQ(lj_dump.atoms_line, "ITEM: ATOMS id type x y z");
  {
    SCOPED_TRACE("orthogonal");
    expect_lammps_reads(dir.path(), dir / "lj.lammpstrj", "block 0 1 0 1 0 1", 4000);
    ASSERT_EQ(run_mdstream("export " + (dir / "lj.mds").string() + " -o " + (dir / "lj.data").string()), 0)
        << cli_stderr();
    expect_read_data_matches(dir.path(), dir / "lj.data", dir / "lj.lammpstrj", 4000);
  }
  ASSERT_EQ(run_mdstream("convert -q --frame 2 " + (tri / "tri.xyz.lammpstrj").string() + " -o " + (dir / "tri.mds").string()), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + (dir / "tri.mds").string() + " -o " + (dir / "tri.dump").string()), 0)
      << cli_stderr();
  // The box LAMMPS wrote for the same frame, to the bit: the store keeps the cell in double.
  const Dump tri_dump = read_dump_text(dir / "tri.dump");
  EXPECT_EQ(tri_dump.header[4], "ITEM: BOX BOUNDS xy xz yz pp pp pp");
  std::ifstream in(tri / "tri.xyz.lammpstrj");
  std::string line;
  int frame = -1;
  std::vector<std::string> lmp_box;
  while (std::getline(in, line)) {
    if (line == "ITEM: TIMESTEP") ++frame;
    if (frame == 2 && line.rfind("ITEM: BOX BOUNDS", 0) == 0)
      for (int i = 0; i < 3 && std::getline(in, line); ++i) lmp_box.push_back(line);
  }
  ASSERT_EQ(lmp_box.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    std::istringstream s(lmp_box[size_t(i)]);
    double v[3];
    s >> v[0] >> v[1] >> v[2];
    for (int k = 0; k < 3; ++k) EXPECT_EQ(tri_dump.bound[i][k], v[k]) << i << "," << k;
  }
  {
    SCOPED_TRACE("triclinic");
    expect_lammps_reads(dir.path(), dir / "tri.dump", "prism 0 1 0 1 0 1 0 0 0", tri_dump.atoms.size());
    ASSERT_EQ(run_mdstream("export " + (dir / "tri.mds").string() + " -o " + (dir / "tri.data").string()), 0)
        << cli_stderr();
    expect_read_data_matches(dir.path(), dir / "tri.data", dir / "tri.dump", tri_dump.atoms.size());
  }
}

// mdstream's reader takes the dump back: the extended XYZ export's particles, in store order,
// with the store's cell, per-particle radii and property.
TEST(ExportLammps, ConvertReadsBackTheXyzExportsParticles) {
  TempDir dir;
  const fs::path prop = textest::cached_lammps_run("in.property_small");
  ASSERT_FALSE(prop.empty());
  // Per-particle radii from a diameter column: the property run's dump with c_pe, diameters by type.
  std::ostringstream with_d;
  {
    std::ifstream f(prop / "dump.property.lammpstrj");
    std::string line;
    bool atoms = false;
    for (int lines = 0; std::getline(f, line); ++lines) {
      if (line == "ITEM: TIMESTEP" && atoms) break;  // the first frame
      if (line.rfind("ITEM: ATOMS", 0) == 0) {
        with_d << line << " diameter\n";
        atoms = true;
        continue;
      }
      if (atoms) {
        std::istringstream s(line);
        long id;
        int type;
        s >> id >> type;
        with_d << line << " " << (type == 1 ? 0.9 + 1e-4 * double(id % 7) : 1.3) << "\n";
      } else {
        with_d << line << "\n";
      }
    }
  }
  textest::write_text(dir / "in.lammpstrj", with_d.str());
  const Dump src = read_dump_text(dir / "in.lammpstrj");
  ASSERT_EQ(src.atoms.size(), 864u);
  const fs::path store = dir / "p.mds";
  ASSERT_EQ(run_mdstream("convert -q --property c_pe " + (dir / "in.lammpstrj").string() + " -o " + store.string()), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + (dir / "p.xyz").string()), 0) << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + (dir / "p.lammpstrj").string()), 0) << cli_stderr();
  const Dump dump = read_dump_text(dir / "p.lammpstrj");
  EXPECT_EQ(dump.atoms_line, "ITEM: ATOMS id type x y z radius c_pe");

  ReaderOptions o;
  o.property = "c_pe";
  auto r = open_reader(dir / "p.lammpstrj", o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const FrameInfo info = (*r)->info();
  auto all = testing::read_all(**r, 500);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->x.size(), src.atoms.size());
  ASSERT_TRUE(info.has_box);
  // The cell the store keeps (its input's), back through the dump's bounds (1 ulp at most).
  auto s = open_reader(dir / "in.lammpstrj", {});
  ASSERT_TRUE(s.ok());
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(info.cell.origin[d], (*s)->info().cell.origin[d], 1e-14);
    EXPECT_NEAR(info.cell.vectors[d][d], (*s)->info().cell.vectors[d][d], 1e-14);
    EXPECT_TRUE(info.cell.periodic[d]);
  }
  // Particle by particle against the XYZ export (species = the LAMMPS type, the store's order).
  std::ifstream xyz(dir / "p.xyz");
  std::string line;
  std::getline(xyz, line);
  std::getline(xyz, line);
  EXPECT_THAT(line, HasSubstr("Properties=species:S:1:pos:R:3:radius:R:1:c_pe:R:1"));
  size_t i = 0;
  std::vector<double> radii;
  for (; std::getline(xyz, line); ++i) {
    ASSERT_LT(i, all->x.size());
    std::istringstream ls(line);
    int species;
    double x, y, z, radius, pe;
    ls >> species >> x >> y >> z >> radius >> pe;
    radii.push_back(radius);
    EXPECT_EQ(all->type[i], species) << i;
    EXPECT_EQ(all->x[i], x) << i;
    EXPECT_EQ(all->y[i], y) << i;
    EXPECT_EQ(all->z[i], z) << i;
    EXPECT_EQ(all->radius[i], float(radius)) << i;
    EXPECT_EQ(all->property[i], float(pe)) << i;
  }
  EXPECT_EQ(i, src.atoms.size());

  // Per-particle radii make the data file atom_style sphere: LAMMPS reads the diameters back
  // (id i + 1 is the store's particle i), and the positions as the dump has them.
  ASSERT_EQ(run_mdstream("export " + store.string() + " -o " + (dir / "p.data").string()), 0) << cli_stderr();
  EXPECT_THAT(textest::read_text(dir / "p.data"), HasSubstr("\nAtoms # sphere\n"));
  ASSERT_TRUE(run_lmp(dir.path(), fmt::format("units lj\natom_style sphere\nboundary p p p\nread_data {}\n"
                                              "write_dump all custom back_s.dump id type x y z diameter modify sort id "
                                              "format float %.17g\n",
                                              (dir / "p.data").string())));
  const Dump back = read_dump_text(dir / "back_s.dump");
  ASSERT_EQ(back.atoms.size(), radii.size());
  for (size_t k = 0; k < radii.size(); ++k) {
    const Atom& a = back.atoms.at(long(k) + 1);
    ASSERT_EQ(a.rest.size(), 1u);
    EXPECT_DOUBLE_EQ(std::stod(a.rest[0]), 2.0 * radii[k]) << k;
  }
  expect_same_atoms(dump, back, radii.size());
}

// Names: an XYZ input's species go to the element column, its types numbered 1, 2 in the store's
// type order; slices and a threshold leave the particles the XYZ export leaves; no cell: the
// bounds of the centres, not periodic; a rotated cell is refused, leaving no file.
TEST(ExportLammps, ElementNamesFiltersAndCellsLammpsCannotHold) {
  TempDir dir;
  std::ostringstream xyz;
  xyz << "60\nProperties=species:S:1:pos:R:3:q:R:1\n";
  for (int i = 0; i < 60; ++i)
    xyz << (i % 3 == 0 ? "Ni" : "Cu") << " " << 0.5 * (i % 5) << " " << 0.25 * (i % 7) << " " << 0.1 * i << " "
        << (i - 30) * 0.1 << "\n";
  textest::write_text(dir / "a.xyz", xyz.str());
  ASSERT_EQ(run_mdstream("convert -q --property q " + (dir / "a.xyz").string() + " -o " + (dir / "a.mds").string()), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + (dir / "a.mds").string() + " -o " + (dir / "a.lammpstrj").string()), 0)
      << cli_stderr();
  const Dump d = read_dump_text(dir / "a.lammpstrj");
  EXPECT_EQ(d.atoms_line, "ITEM: ATOMS id type x y z q element");
  // No cell: the spheres' box, the centres' bounds (x 0..2, z 0..5.9) grown by the radius.
  EXPECT_EQ(d.header[4], "ITEM: BOX BOUNDS ff ff ff");
  const double r = -d.bound[0][0];
  EXPECT_GT(r, 0.0);
  EXPECT_DOUBLE_EQ(d.bound[0][1], 2.0 + r);
  EXPECT_DOUBLE_EQ(d.bound[2][1], 5.9 + r);
  // ... which a non-periodic LAMMPS box takes with every atom (none on its faces).
  ASSERT_EQ(run_mdstream("export " + (dir / "a.mds").string() + " -o " + (dir / "a.data").string()), 0)
      << cli_stderr();
  ASSERT_TRUE(run_lmp(dir.path(), fmt::format("units lj\natom_style atomic\nboundary f f f\nread_data {}\nmass * 1.0\n"
                                              "write_dump all custom back_f.dump id type x y z modify sort id\n",
                                              (dir / "a.data").string())));
  EXPECT_EQ(read_dump_text(dir / "back_f.dump").atoms.size(), 60u);
  ASSERT_EQ(d.atoms.size(), 60u);
  std::map<int, std::string> names;
  for (const auto& [id, a] : d.atoms) {
    ASSERT_EQ(a.rest.size(), 2u);
    auto [it, fresh] = names.emplace(a.type, a.rest[1]);
    EXPECT_EQ(it->second, a.rest[1]) << "type " << a.type << " has two names";
  }
  EXPECT_EQ(names.size(), 2u);
  EXPECT_TRUE(names.count(1) && names.count(2));
  EXPECT_NE(names[1], names[2]);

  // The same particles as the XYZ export under a slice and a threshold.
  const std::string filter = " --slice 0,0,1,3 --threshold=-1:1.5";
  ASSERT_EQ(run_mdstream("export " + (dir / "a.mds").string() + " -o " + (dir / "f.lammpstrj").string() + filter), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + (dir / "a.mds").string() + " -o " + (dir / "f.xyz").string() + filter), 0)
      << cli_stderr();
  const Dump f = read_dump_text(dir / "f.lammpstrj");
  std::ifstream fx(dir / "f.xyz");
  std::string line;
  std::getline(fx, line);
  ASSERT_EQ(f.atoms.size(), std::stoul(line));
  EXPECT_GT(f.atoms.size(), 5u);
  EXPECT_LT(f.atoms.size(), 30u);
  std::getline(fx, line);
  long id = 1;
  for (; std::getline(fx, line); ++id) {
    std::istringstream s(line);
    std::string species;
    double x[3], q;
    s >> species >> x[0] >> x[1] >> x[2] >> q;
    const Atom& a = f.atoms.at(id);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a.x[k], x[k]) << id;
    EXPECT_EQ(a.rest[0], fmt::format("{}", q)) << id;
    EXPECT_EQ(a.rest[1], species) << id;
  }

  // A cell rotated out of LAMMPS' form (a not along x): refused, naming the store; no file.
  textest::write_text(dir / "rot.xyz",
                      "2\nLattice=\"0 10 0 -10 0 0 0 0 10\" pbc=\"T T T\" Properties=species:S:1:pos:R:3\n"
                      "Cu 1 1 1\nCu 2 2 2\n");
  ASSERT_EQ(run_mdstream("convert -q " + (dir / "rot.xyz").string() + " -o " + (dir / "rot.mds").string()), 0)
      << cli_stderr();
  EXPECT_NE(run_mdstream("export " + (dir / "rot.mds").string() + " -o " + (dir / "rot.lammpstrj").string()), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr((dir / "rot.mds").string() + ": the cell's edge vectors a = (0, 10, 0)"));
  EXPECT_THAT(cli_stderr(), HasSubstr("export to .xyz keeps the cell"));
  EXPECT_FALSE(fs::exists(dir / "rot.lammpstrj"));
  ASSERT_EQ(run_mdstream("export " + (dir / "rot.mds").string() + " -o " + (dir / "rot.xyz2.xyz").string()), 0);
}

// A series keeps each type's number in every frame, though its XYZ frames list the species in
// another order (each frame's store numbers them as it meets them).
TEST(ExportLammps, ASeriesNumbersTheTypesAlikeInEveryFrame) {
  TempDir dir;
  textest::write_text(dir / "w.xyz",
                      "3\nProperties=species:S:1:pos:R:3\nO 0 0 0\nH 1 0 0\nH 0 1 0\n"
                      "4\nProperties=species:S:1:pos:R:3\nH 0 0 1\nC 2 2 2\nO 1 1 1\nH 2 2 0\n");
  ASSERT_EQ(run_mdstream("convert -q --frames : " + (dir / "w.xyz").string() + " -o " + (dir / "w.mds.series").string()), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + (dir / "w.mds.series").string() + " -o " + (dir / "w.lammpstrj").string()), 0)
      << cli_stderr();
  std::map<int, std::string> element_of;
  size_t atoms = 0, frames = 0;
  std::istringstream in(textest::read_text(dir / "w.lammpstrj"));
  bool in_atoms = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("ITEM:", 0) == 0) {
      in_atoms = line == "ITEM: ATOMS id type x y z element";
      frames += line == "ITEM: TIMESTEP";
      continue;
    }
    if (!in_atoms) continue;
    std::istringstream ls(line);
    long id;
    int type;
    double x, y, z;
    std::string element;
    ls >> id >> type >> x >> y >> z >> element;
    const auto [it, fresh] = element_of.emplace(type, element);
    EXPECT_EQ(it->second, element) << "type " << type << " is " << it->second << " and " << element;
    ++atoms;
  }
  EXPECT_EQ(frames, 2u);
  EXPECT_EQ(atoms, 7u);
  EXPECT_EQ(element_of.size(), 3u);  // O, H, C: 1, 2, 3 in the order the frames list them
  EXPECT_EQ(element_of[1], "O");
  EXPECT_EQ(element_of[2], "H");
  EXPECT_EQ(element_of[3], "C");
}

// A cell that is not periodic along an axis holds the atoms beyond it in LAMMPS' box (a molecule
// drawn in a box too small), so that read_data under `boundary f f f` keeps them all.
TEST(ExportLammps, ANonPeriodicCellGrowsToHoldItsAtoms) {
  TempDir dir;
  textest::write_text(dir / "m.xyz", "3\nLattice=\"10 0 0 0 10 0 0 0 10\" pbc=\"F F T\" Properties=species:S:1:pos:R:3\n"
                                     "C -1 5 5\nC 5 11 5\nC 5 5 5\n");
  ASSERT_EQ(run_mdstream("convert -q " + (dir / "m.xyz").string() + " -o " + (dir / "m.mds").string()), 0) << cli_stderr();
  ASSERT_EQ(run_mdstream("export " + (dir / "m.mds").string() + " -o " + (dir / "m.lammpstrj").string()), 0)
      << cli_stderr();
  const Dump d = read_dump_text(dir / "m.lammpstrj");
  EXPECT_EQ(d.header[4], "ITEM: BOX BOUNDS ff ff pp");
  EXPECT_LT(d.bound[0][0], -1.0);  // x grew below the cell
  EXPECT_EQ(d.bound[0][1], 10.0);
  EXPECT_EQ(d.bound[1][0], 0.0);
  EXPECT_GT(d.bound[1][1], 11.0);  // y grew above it
  EXPECT_EQ(d.bound[2][0], 0.0);   // z periodic: the cell's
  EXPECT_EQ(d.bound[2][1], 10.0);
  ASSERT_EQ(run_mdstream("export " + (dir / "m.mds").string() + " -o " + (dir / "m.data").string()), 0) << cli_stderr();
  ASSERT_TRUE(run_lmp(dir.path(), fmt::format("units lj\natom_style atomic\nboundary f f p\nread_data {}\nmass * 1.0\n"
                                              "write_dump all custom back_m.dump id type x y z modify sort id\n",
                                              (dir / "m.data").string())));
  EXPECT_EQ(read_dump_text(dir / "back_m.dump").atoms.size(), 3u);
}

}  // namespace
}  // namespace mds
