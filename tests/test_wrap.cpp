// `convert --wrap` (readers/wrap_reader.h) against LAMMPS itself: the unwrapped dump of a
// triclinic run (xu yu zu), wrapped, gives the positions of the wrapped dump LAMMPS wrote at the
// same steps (x y z), particle for particle; the wrap's inverse and its edge cases (a point on a
// face, non-periodic vectors, a flat cell), and the command line (the converted store lies in the
// cell; inputs without a usable cell are errors naming the file).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "readers/lammps_reader.h"
#include "readers/wrap_reader.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::run_mdstream;
namespace fs = std::filesystem;

SimulationCell tilted() {
  SimulationCell c;
  c.origin[0] = -2.0;
  c.origin[1] = 1.0;
  const double v[3][3] = {{10.0, 0.0, 0.0}, {3.0, 8.0, 0.0}, {-2.0, 1.5, 6.0}};
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k < 3; ++k) c.vectors[d][k] = v[d][k];
  c.periodic[0] = c.periodic[1] = c.periodic[2] = true;
  return c;
}

TEST(CellWrap, FractionalCoordinatesModuloOne) {
  const SimulationCell c = tilted();
  auto w = CellWrap::make(c, "t");
  ASSERT_TRUE(w.ok()) << w.error().message;
  // A point 2a - b + 3c away from one inside comes back to it; one inside keeps its bits.
  const auto inside = c.at(0.25, 0.5, 0.75);
  double x = inside[0] + 2 * 10.0 - 3.0 + 3 * -2.0, y = inside[1] - 8.0 + 3 * 1.5, z = inside[2] + 3 * 6.0;
  EXPECT_TRUE(w->apply(x, y, z));
  EXPECT_NEAR(x, inside[0], 1e-12);
  EXPECT_NEAR(y, inside[1], 1e-12);
  EXPECT_NEAR(z, inside[2], 1e-12);
  double a = inside[0], b = inside[1], d = inside[2];
  w->apply(a, b, d);
  EXPECT_EQ(a, inside[0]);
  EXPECT_EQ(b, inside[1]);
  EXPECT_EQ(d, inside[2]);
  // On the far face (f = 1) a point goes to the near one (f = 0): [0, 1).
  const auto far = c.at(1.0, 0.5, 0.5), near = c.at(0.0, 0.5, 0.5);
  double fx = far[0], fy = far[1], fz = far[2];
  w->apply(fx, fy, fz);
  EXPECT_NEAR(fx, near[0], 1e-12);
  // More than 2^50 cells away: refused, the point unchanged (whole-vector shifts would lose it).
  double hx = 1e20, hy = 0.0, hz = 0.0;
  EXPECT_FALSE(w->apply(hx, hy, hz));
  EXPECT_EQ(hx, 1e20);
  EXPECT_TRUE(w->apply(fx, fy, fz));
  // Along a vector that is not periodic nothing moves.
  SimulationCell open = c;
  open.periodic[2] = false;
  auto wo = CellWrap::make(open, "t");
  ASSERT_TRUE(wo.ok());
  double ox = inside[0] + 3 * -2.0, oy = inside[1] + 3 * 1.5, oz = inside[2] + 3 * 6.0;
  wo->apply(ox, oy, oz);
  EXPECT_NEAR(oz, inside[2] + 18.0, 1e-12);
  // Cells that cannot wrap.
  SimulationCell none = c;
  none.periodic[0] = none.periodic[1] = none.periodic[2] = false;
  EXPECT_THAT(CellWrap::make(none, "n.xyz").error().message, HasSubstr("n.xyz: --wrap: the cell is periodic along none"));
  SimulationCell flat = c;
  flat.vectors[2][0] = flat.vectors[2][1] = flat.vectors[2][2] = 0.0;
  EXPECT_THAT(CellWrap::make(flat, "f.xyz").error().message, HasSubstr("f.xyz: --wrap: the cell is flat"));
}

struct Frame {
  std::vector<double> x, y, z;
  std::vector<int64_t> id;
  SimulationCell cell;
};

Frame read_frame(const fs::path& p, int64_t frame, bool wrap) {
  ReaderOptions o;
  o.format = InputFormat::lammps;
  o.frame = frame;
  o.wrap = wrap;
  Frame f;
  auto r = open_reader(p, o);
  EXPECT_TRUE(r.ok()) << r.error().message;
  if (!r.ok()) return f;
  f.cell = (*r)->info().cell;
  ParticleBatch b;
  for (;;) {
    auto n = (*r)->read(b, 100);
    EXPECT_TRUE(n.ok()) << n.error().message;
    if (!n.ok() || *n == 0) break;
    f.x.insert(f.x.end(), b.x.begin(), b.x.end());
    f.y.insert(f.y.end(), b.y.begin(), b.y.end());
    f.z.insert(f.z.end(), b.z.begin(), b.z.end());
    f.id.insert(f.id.end(), b.id.begin(), b.id.end());
  }
  return f;
}

TEST(CellWrap, UnwrappedLammpsDumpWrapsToLammpsOwnWrappedPositions) {
  const fs::path dir = textest::cached_lammps_run("in.triclinic_small", /*with_log=*/true);
  ASSERT_FALSE(dir.empty()) << "lmp failed on in.triclinic_small";
  size_t moved = 0, total = 0;
  for (int64_t frame : {1, 2}) {  // after 50 and 100 steps: atoms have crossed the faces
    SCOPED_TRACE(frame);
    const Frame lammps = read_frame(dir / "tri.xyz.lammpstrj", frame, false);
    const Frame unwrapped = read_frame(dir / "tri.unwrapped.lammpstrj", frame, false);
    const Frame wrapped = read_frame(dir / "tri.unwrapped.lammpstrj", frame, true);
    ASSERT_EQ(wrapped.x.size(), lammps.x.size());
    ASSERT_EQ(wrapped.id, lammps.id);  // the same atoms in the same order (one process)
    auto w = CellWrap::make(lammps.cell, "t");
    ASSERT_TRUE(w.ok());
    for (size_t i = 0; i < lammps.x.size(); ++i) {
      ++total;
      moved += unwrapped.x[i] != wrapped.x[i] || unwrapped.y[i] != wrapped.y[i] || unwrapped.z[i] != wrapped.z[i];
      // Equal to LAMMPS' wrapped position (dumps at %.15g), or a whole cell vector away where the
      // atom sits on a face (LAMMPS wraps during the run, with its own rounding).
      const double d[3] = {wrapped.x[i] - lammps.x[i], wrapped.y[i] - lammps.y[i], wrapped.z[i] - lammps.z[i]};
      for (int k = 0; k < 3; ++k) {
        const double f = w->inverse[k][0] * d[0] + w->inverse[k][1] * d[1] + w->inverse[k][2] * d[2];
        ASSERT_NEAR(f, std::round(f), 1e-9) << "atom " << lammps.id[i] << " axis " << k;
        if (std::round(f) != 0.0) {
          const double r[3] = {lammps.x[i] - lammps.cell.origin[0], lammps.y[i] - lammps.cell.origin[1],
                               lammps.z[i] - lammps.cell.origin[2]};
          const double fl = w->inverse[k][0] * r[0] + w->inverse[k][1] * r[1] + w->inverse[k][2] * r[2];
          EXPECT_TRUE(fl < 1e-9 || fl > 1.0 - 1e-9) << "atom " << lammps.id[i] << " a cell away, not on a face";
        }
      }
    }
  }
  EXPECT_GT(moved, 0u) << "no atom crossed a face: the test shows nothing";
  EXPECT_GT(total, 1000u);
}

TEST(CellWrap, ConvertWrapsIntoTheCellAndRefusesInputsWithoutOne) {
  const fs::path dir = textest::cached_lammps_run("in.triclinic_small", /*with_log=*/true);
  ASSERT_FALSE(dir.empty());
  textest::TempDir tmp("wrap_cli");
  const fs::path store = tmp.path() / "w.mds", report = tmp.path() / "w.json";
  ASSERT_EQ(run_mdstream("convert -q --wrap --frame last " + (dir / "tri.unwrapped.lammpstrj").string() + " -o " +
                         store.string() + " --json-report " + report.string()),
            0)
      << cli_stderr();
  std::ifstream rf(report);
  const nlohmann::json j = nlohmann::json::parse(rf);
  EXPECT_EQ(j["wrapped"], true);
  // Every centre lies in the cell: its bounds within the cell's box (to the quantization step).
  const auto cell = j["cell"];
  double lo[3], hi[3];
  SimulationCell c;
  for (int d = 0; d < 3; ++d) {
    c.origin[d] = cell["origin"][d];
    for (int k = 0; k < 3; ++k) c.vectors[d][k] = cell["vectors"][d][k];
  }
  c.bounds(lo, hi);
  for (int d = 0; d < 3; ++d) {
    EXPECT_GE(j["bounds_min"][d].get<double>(), lo[d] - 1e-6) << d;
    EXPECT_LE(j["bounds_max"][d].get<double>(), hi[d] + 1e-6) << d;
  }
  // No cell, or one periodic along nothing: errors naming the file, no output.
  const fs::path xyz = tmp.path() / "plain.xyz", open = tmp.path() / "open.xyz", out = tmp.path() / "x.mds";
  std::ofstream(xyz) << "1\ncomment\nC 1 2 3\n";
  std::ofstream(open) << "1\nLattice=\"4 0 0 0 4 0 0 0 4\" pbc=\"F F F\" Properties=species:S:1:pos:R:3\nC 1 2 3\n";
  EXPECT_EQ(run_mdstream("convert --wrap " + xyz.string() + " -o " + out.string()), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr(xyz.string() + ": --wrap: the input has no simulation cell"));
  EXPECT_EQ(run_mdstream("convert --wrap " + open.string() + " -o " + out.string()), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr(open.string() + ": --wrap: the cell is periodic along none"));
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace mds
