// `convert --replicate` (readers/replicate_reader.h) against LAMMPS itself: a triclinic run's
// dump, replicated 2 x 2 x 3, gives the atoms LAMMPS' own `replicate 2 2 3` wrote, atom for atom
// (as sets: LAMMPS shifts unwrapped positions, so its copies of an atom come in another order); the
// images' order and bits, the replicated cell, and the command line (counts, report, errors
// naming the file, no output on error).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "readers/replicate_reader.h"
#include "readers/wrap_reader.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::run_mdstream;
namespace fs = std::filesystem;

constexpr ReplicateCounts kCounts = {2, 2, 3};

TEST(Replicate, ParsesCounts) {
  EXPECT_EQ(*parse_replicate_counts("2,2,3"), (ReplicateCounts{2, 2, 3}));
  EXPECT_EQ(*parse_replicate_counts("4x1x65536"), (ReplicateCounts{4, 1, 65536}));
  for (const char* bad : {"", "2", "2,2", "2,2,2,2", "0,1,1", "2,-1,1", "a,b,c", "2,2,65537", "2;2;2", "2,2,3 "})
    EXPECT_FALSE(parse_replicate_counts(bad).ok()) << bad;
  EXPECT_THAT(parse_replicate_counts("2,2").error().message, HasSubstr("--replicate '2,2': expected three image counts"));
}

ReaderOptions lammps_options(bool wrap, ReplicateCounts counts) {
  ReaderOptions o;
  o.format = InputFormat::lammps;
  o.wrap = wrap;
  o.replicate = counts;
  return o;
}

TEST(Replicate, EachBatchOncePerImageInLammpsOrder) {
  const fs::path dir = textest::cached_lammps_run("in.replicate_small");
  ASSERT_FALSE(dir.empty()) << "lmp failed on in.replicate_small";
  const fs::path base = dir / "rep.base.lammpstrj";
  const textest::ReadAll plain = textest::read_all(open_reader(base, lammps_options(false, {1, 1, 1})));
  ASSERT_FALSE(plain.error) << plain.error->message;
  const size_t n = plain.all.size();
  ASSERT_EQ(n, 240u);
  auto opened = open_reader(base, lammps_options(false, kCounts));
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  ParticleReader& r = **opened;
  // The frame: 12 times the atoms, in the cell 2a, 2b, 3c at the same origin.
  const SimulationCell& c = plain.info.cell;
  EXPECT_EQ(r.info().particle_count, 12 * n);
  for (int v = 0; v < 3; ++v)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(r.info().cell.vectors[v][k], c.vectors[v][k] * kCounts[v]);
  double lo[3], hi[3];
  r.info().cell.bounds(lo, hi);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(r.info().cell.origin[k], c.origin[k]);
    EXPECT_EQ(r.info().box_lo[k], lo[k]);
    EXPECT_EQ(r.info().box_hi[k], hi[k]);
  }
  // Batches of 100 (the frame is 240: batches of 100, 100, 40), each handed out 12 times.
  ParticleBatch b;
  size_t begin = 0, reads = 0, total = 0;
  while (begin < n) {
    const size_t len = std::min<size_t>(100, n - begin);
    for (uint32_t image = 0; image < 12; ++image) {
      auto got = r.read(b, 100);
      ASSERT_TRUE(got.ok()) << got.error().message;
      ASSERT_EQ(*got, len) << "read " << reads;
      ++reads;
      total += *got;
      const uint32_t i = image % 2, j = image / 2 % 2, k = image / 4;
      for (size_t p = 0; p < len; ++p) {
        const size_t q = begin + p;
        EXPECT_EQ(b.type[p], plain.all.type[q]);
        EXPECT_EQ(b.id[p], plain.all.id[q]);
        if (image == 0) {  // the batch as read, bit for bit
          EXPECT_EQ(b.x[p], plain.all.x[q]);
          EXPECT_EQ(b.y[p], plain.all.y[q]);
          EXPECT_EQ(b.z[p], plain.all.z[q]);
        } else {
          const double* in[3] = {plain.all.x.data(), plain.all.y.data(), plain.all.z.data()};
          const double* out[3] = {b.x.data(), b.y.data(), b.z.data()};
          for (int a = 0; a < 3; ++a)
            EXPECT_EQ(out[a][p], in[a][q] + (i * c.vectors[0][a] + j * c.vectors[1][a] + k * c.vectors[2][a]))
                << "image " << image << " atom " << q << " axis " << a;
        }
      }
    }
    begin += len;
  }
  auto end = r.read(b, 100);
  ASSERT_TRUE(end.ok());
  EXPECT_EQ(*end, 0u);
  EXPECT_EQ(total, 12 * n);
}

TEST(Replicate, HandsOutAtMostWhatIsAskedFor) {
  const fs::path dir = textest::cached_lammps_run("in.replicate_small");
  ASSERT_FALSE(dir.empty()) << "lmp failed on in.replicate_small";
  const fs::path base = dir / "rep.base.lammpstrj";
  const textest::ReadAll plain = textest::read_all(open_reader(base, lammps_options(false, {1, 1, 1})));
  ASSERT_FALSE(plain.error);
  auto opened = open_reader(base, lammps_options(false, {2, 1, 1}));
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  ParticleReader& r = **opened;
  const double* a = plain.info.cell.vectors[0];
  // (asked, got, image, first particle): a batch of 100 read with the first call, its second
  // image in two parts, then the next batch.
  const size_t steps[][4] = {{100, 100, 0, 0}, {30, 30, 1, 0}, {1000, 70, 1, 30}, {100, 100, 0, 100}, {5, 5, 1, 100}};
  ParticleBatch b;
  for (const auto& s : steps) {
    auto got = r.read(b, s[0]);
    ASSERT_TRUE(got.ok()) << got.error().message;
    ASSERT_EQ(*got, s[1]) << "asked " << s[0];
    ASSERT_EQ(b.id.size(), s[1]);
    for (size_t p = 0; p < s[1]; ++p) {
      const size_t q = s[3] + p;
      EXPECT_EQ(b.id[p], plain.all.id[q]);
      EXPECT_EQ(b.x[p], plain.all.x[q] + (s[2] ? a[0] : 0.0));
      EXPECT_EQ(b.y[p], plain.all.y[q] + (s[2] ? a[1] : 0.0));
    }
  }
}

TEST(Replicate, GivesTheAtomsOfLammpsOwnReplicate) {
  const fs::path dir = textest::cached_lammps_run("in.replicate_small");
  ASSERT_FALSE(dir.empty()) << "lmp failed on in.replicate_small";
  const textest::ReadAll lammps =
      textest::read_all(open_reader(dir / "rep.2x2x3.lammpstrj", lammps_options(false, {1, 1, 1})));
  ASSERT_FALSE(lammps.error) << lammps.error->message;
  // LAMMPS wraps the replicated atoms into its new box; so does --wrap before the images are made.
  auto opened = open_reader(dir / "rep.base.lammpstrj", lammps_options(true, kCounts));
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  ParticleReader& r = **opened;
  const size_t n = r.info().particle_count / 12;
  ASSERT_EQ(lammps.all.size(), 12 * n);
  // The same cell as LAMMPS' replicated box (which the dump prints to 17 digits).
  const SimulationCell& mine = r.info().cell;
  const SimulationCell& theirs = lammps.info.cell;
  for (int v = 0; v < 3; ++v)
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(mine.vectors[v][k], theirs.vectors[v][k], 1e-12 * std::abs(theirs.vectors[v][v])) << v << " " << k;
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(mine.origin[k], theirs.origin[k], 1e-12);
  // A read of the whole frame is one image. LAMMPS' copy m of atom t is atom t + m n (ids 1..n),
  // but LAMMPS shifts the unwrapped position (its image flags added back), so its copies of an
  // atom are ours in another order: each of its 12 must be one of ours, a whole number of the
  // new cell's vectors apart, and no two the same.
  std::vector<ParticleBatch> images(12);
  for (auto& img : images) {
    auto got = r.read(img, 1'000'000);
    ASSERT_TRUE(got.ok()) << got.error().message;
    ASSERT_EQ(*got, n);
  }
  auto w = CellWrap::make(theirs, "t");
  ASSERT_TRUE(w.ok());
  size_t on_face = 0, permuted = 0;
  for (size_t t = 0; t < n; ++t) {
    std::vector<bool> used(12, false);
    for (size_t m = 0; m < 12; ++m) {
      const size_t T = t + m * n;
      ASSERT_EQ(lammps.all.id[T], int64_t(T + 1));  // sorted by id, ids 1..12n
      int match = -1;
      double face = 0;  // whole vectors apart
      for (size_t ours = 0; ours < 12 && match < 0; ++ours) {
        const ParticleBatch& img = images[ours];
        ASSERT_EQ(img.id[t], int64_t(t + 1));
        const double d[3] = {img.x[t] - lammps.all.x[T], img.y[t] - lammps.all.y[T], img.z[t] - lammps.all.z[T]};
        bool integral = true;
        face = 0;
        for (int k = 0; k < 3; ++k) {
          const double f = w->inverse[k][0] * d[0] + w->inverse[k][1] * d[1] + w->inverse[k][2] * d[2];
          integral &= std::abs(f - std::round(f)) <= 1e-9;
          face += std::abs(std::round(f));
        }
        if (integral) match = int(ours);
      }
      ASSERT_GE(match, 0) << "LAMMPS atom " << T + 1 << " is none of our images of atom " << t + 1;
      EXPECT_FALSE(used[size_t(match)]) << "atom " << T + 1;
      used[size_t(match)] = true;
      EXPECT_EQ(images[size_t(match)].type[t], lammps.all.type[T]);
      permuted += size_t(match) != m;
      on_face += face != 0;  // equal up to a whole vector: an atom on a face of the new cell
    }
  }
  EXPECT_GT(permuted, 0u) << "no atom with image flags: the order was not tested";
  EXPECT_LE(on_face, 12u);
}

TEST(Replicate, ConvertWritesTheImagesAndTheGrownCell) {
  const fs::path dir = textest::cached_lammps_run("in.replicate_small");
  ASSERT_FALSE(dir.empty()) << "lmp failed on in.replicate_small";
  textest::TempDir tmp("replicate_cli");
  const fs::path store = tmp.path() / "r.mds", report = tmp.path() / "r.json";
  ASSERT_EQ(run_mdstream("convert -q --wrap --replicate 2x2x3 " + (dir / "rep.base.lammpstrj").string() + " -o " +
                         store.string() + " --json-report " + report.string()),
            0)
      << cli_stderr();
  std::ifstream rf(report);
  const nlohmann::json j = nlohmann::json::parse(rf);
  EXPECT_EQ(j["particles"], 2880);
  EXPECT_EQ(j["replicated"], nlohmann::json::array({2, 2, 3}));
  // The store's cell is LAMMPS' replicated box; every centre lies in it (to the quantization step).
  const textest::ReadAll lammps =
      textest::read_all(open_reader(dir / "rep.2x2x3.lammpstrj", lammps_options(false, {1, 1, 1})));
  ASSERT_FALSE(lammps.error);
  double lo[3], hi[3];
  lammps.info.cell.bounds(lo, hi);
  for (int d = 0; d < 3; ++d) {
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(j["cell"]["vectors"][d][k].get<double>(), lammps.info.cell.vectors[d][k], 1e-9) << d << " " << k;
    EXPECT_GE(j["bounds_min"][d].get<double>(), lo[d] - 1e-6) << d;
    EXPECT_LE(j["bounds_max"][d].get<double>(), hi[d] + 1e-6) << d;
  }
  // What LAMMPS' replicate wrote converts to the same bounds (to the quantization step).
  const fs::path theirs = tmp.path() / "l.mds", theirs_report = tmp.path() / "l.json";
  ASSERT_EQ(run_mdstream("convert -q " + (dir / "rep.2x2x3.lammpstrj").string() + " -o " + theirs.string() +
                         " --json-report " + theirs_report.string()),
            0)
      << cli_stderr();
  std::ifstream lf(theirs_report);
  const nlohmann::json l = nlohmann::json::parse(lf);
  EXPECT_EQ(l["replicated"], nlohmann::json::array({1, 1, 1}));
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(j["bounds_min"][d].get<double>(), l["bounds_min"][d].get<double>(), 1e-3) << d;
    EXPECT_NEAR(j["bounds_max"][d].get<double>(), l["bounds_max"][d].get<double>(), 1e-3) << d;
  }
}

TEST(Replicate, RefusesInputsItCannotReplicate) {
  const fs::path dir = textest::cached_lammps_run("in.replicate_small");
  ASSERT_FALSE(dir.empty()) << "lmp failed on in.replicate_small";
  textest::TempDir tmp("replicate_bad");
  const fs::path out = tmp.path() / "x.mds";
  const fs::path plain = tmp.path() / "plain.xyz", flat = tmp.path() / "flat.xyz";
  std::ofstream(plain) << "1\ncomment\nC 1 2 3\n";
  std::ofstream(flat) << "1\nLattice=\"4 0 0 0 4 0 0 0 0\" Properties=species:S:1:pos:R:3\nC 1 2 0\n";
  const fs::path huge = tmp.path() / "huge.xyz", parallel = tmp.path() / "parallel.xyz";
  const fs::path big = tmp.path() / "big.xyz";
  std::ofstream(big) << "1\nLattice=\"4e26 0 0 0 4 0 0 0 4\" Properties=species:S:1:pos:R:3\nC 1 2 0\n";
  std::ofstream(parallel) << "1\nLattice=\"4 0 0 -8 0 0 0 0 4\" Properties=species:S:1:pos:R:3\nC 1 2 0\n";
  std::ofstream(huge) << "1\nLattice=\"4e31 0 0 0 4 0 0 0 4\" Properties=species:S:1:pos:R:3\nC 1 2 0\n";
  // No cell; a zero vector with more than one image along it; bad counts; too many particles.
  EXPECT_EQ(run_mdstream("convert --replicate 2,2,2 " + plain.string() + " -o " + out.string()), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr(plain.string() + ": --replicate: the input has no simulation cell"));
  EXPECT_EQ(run_mdstream("convert --replicate 2,2,2 " + flat.string() + " -o " + out.string()), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr(flat.string() + ": --replicate: the cell's vector c has zero length"));
  EXPECT_EQ(run_mdstream("convert --replicate 2,1,1 " + huge.string() + " -o " + out.string()), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr(huge.string() + ": --replicate: the cell is not finite or beyond 1e+30"));
  EXPECT_EQ(run_mdstream("convert --replicate 2,2,1 " + parallel.string() + " -o " + out.string()), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr(parallel.string() + ": --replicate: the cell's vectors ab are parallel"));
  EXPECT_EQ(run_mdstream("convert --replicate 30000,1,1 " + big.string() + " -o " + out.string()), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr(big.string() + ": --replicate 30000x1x1: the grown cell is beyond 1e+30"));
  EXPECT_EQ(run_mdstream("convert --replicate 2,0,1 " + plain.string() + " -o " + out.string()), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--replicate '2,0,1': expected three image counts"));
  const std::string base = (dir / "rep.base.lammpstrj").string();
  EXPECT_EQ(run_mdstream("convert --replicate 65536,65536,2 " + base + " -o " + out.string()), 1);
  EXPECT_THAT(cli_stderr(), HasSubstr(base + ": --replicate 65536x65536x2: 240 particles x 8589934592 images is more than"));
  EXPECT_FALSE(fs::exists(out));
  // Along the flat vector a single image is fine: the cell stays flat, the particles as they are.
  EXPECT_EQ(run_mdstream("convert -q --replicate 3,2,1 " + flat.string() + " -o " + out.string()), 0) << cli_stderr();
  EXPECT_TRUE(fs::exists(out));
}

}  // namespace
}  // namespace mds
