// Tests of `mdstream synth` (preprocess/synth): determinism, exact particle counts, valid
// LAMMPS dumps (parsed here with plain code and through the project's reader), gzip output,
// frames, type mapping, and the density structure that each scene is meant to have.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "readers/reader.h"
#include "synth/synth.h"

namespace fs = std::filesystem;
using mds::synth::Scene;
using mds::synth::SynthOptions;

namespace {

fs::path temp_dir() {
  static fs::path dir = [] {
    fs::path d = fs::path(testing::TempDir()) / ("mds_test_synth_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

std::string read_file(const fs::path& p) {
  std::string out;
  if (p.extension() == ".gz") {
    gzFile f = gzopen(p.c_str(), "rb");
    if (!f) return out;
    char buf[1 << 16];
    int n;
    while ((n = gzread(f, buf, sizeof buf)) > 0) out.append(buf, static_cast<size_t>(n));
    gzclose(f);
    return out;
  }
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Frame {
  int64_t timestep = 0;
  uint64_t n = 0;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  std::vector<int64_t> id;
  std::vector<int> type;
  std::vector<double> x, y, z;
};

// Straightforward LAMMPS dump parser for `ITEM: ATOMS id type x y z`. Returns "" or an error.
std::string parse_dump(const std::string& text, std::vector<Frame>& frames) {
  size_t pos = 0;
  size_t line_no = 0;
  auto next_line = [&](std::string_view& line) {
    if (pos >= text.size()) return false;
    size_t e = text.find('\n', pos);
    if (e == std::string::npos) e = text.size();
    line = std::string_view(text).substr(pos, e - pos);
    pos = e + 1;
    ++line_no;
    return true;
  };
  std::string_view line;
  while (next_line(line)) {
    Frame f;
    if (line != "ITEM: TIMESTEP") return "line " + std::to_string(line_no) + ": expected ITEM: TIMESTEP";
    if (!next_line(line)) return "truncated";
    f.timestep = std::stoll(std::string(line));
    if (!next_line(line) || line != "ITEM: NUMBER OF ATOMS") return "expected NUMBER OF ATOMS";
    if (!next_line(line)) return "truncated";
    f.n = std::stoull(std::string(line));
    if (!next_line(line) || line != "ITEM: BOX BOUNDS pp pp pp") return "expected BOX BOUNDS pp pp pp";
    for (int a = 0; a < 3; ++a) {
      if (!next_line(line)) return "truncated box";
      std::istringstream ls{std::string(line)};
      if (!(ls >> f.lo[a] >> f.hi[a])) return "bad box line";
    }
    if (!next_line(line) || line != "ITEM: ATOMS id type x y z") return "expected ITEM: ATOMS id type x y z";
    for (uint64_t i = 0; i < f.n; ++i) {
      if (!next_line(line)) return "frame ends after " + std::to_string(i) + " atoms";
      std::string s(line);
      char* p = s.data();
      char* end = nullptr;
      const long long id = std::strtoll(p, &end, 10);
      if (end == p) return "line " + std::to_string(line_no) + ": bad id";
      p = end;
      const long t = std::strtol(p, &end, 10);
      if (end == p) return "line " + std::to_string(line_no) + ": bad type";
      p = end;
      double v[3];
      for (double& c : v) {
        c = std::strtod(p, &end);
        if (end == p || !std::isfinite(c)) return "line " + std::to_string(line_no) + ": bad coordinate";
        p = end;
      }
      while (*p == ' ') ++p;
      if (*p != '\0') return "line " + std::to_string(line_no) + ": trailing text";
      f.id.push_back(id);
      f.type.push_back(static_cast<int>(t));
      f.x.push_back(v[0]);
      f.y.push_back(v[1]);
      f.z.push_back(v[2]);
    }
    frames.push_back(std::move(f));
  }
  return "";
}

struct Written {
  fs::path path;
  mds::synth::SceneSummary summary;
  std::vector<Frame> frames;
};

// Writes a scene and parses it back; fails the test on any error.
Written make(Scene scene, uint64_t n, uint64_t seed = 1, const std::string& name = "", int frames = 1, int types = 0,
             int threads = 0) {
  SynthOptions o;
  o.scene = scene;
  o.particles = n;
  o.seed = seed;
  o.frames = frames;
  o.types = types;
  o.threads = threads;
  Written w;
  w.path = temp_dir() / (name.empty() ? std::string(mds::synth::scene_name(scene)) + "_" + std::to_string(n) + "_" +
                                            std::to_string(seed) + ".dump"
                                      : name);
  auto r = mds::synth::write_scene(o, w.path);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  if (!r.ok()) return w;
  w.summary = *r;
  const std::string err = parse_dump(read_file(w.path), w.frames);
  EXPECT_EQ(err, "") << w.path;
  return w;
}

const Scene kScenes[] = {Scene::ablation, Scene::porous, Scene::gas, Scene::shell};

void expect_valid_frame(const Frame& f, uint64_t n, int types, const std::string& what) {
  ASSERT_EQ(f.n, n) << what;
  ASSERT_EQ(f.id.size(), n) << what;
  for (uint64_t i = 0; i < n; ++i) {
    ASSERT_EQ(f.id[i], static_cast<int64_t>(i + 1)) << what;
    ASSERT_GE(f.type[i], 1) << what;
    ASSERT_LE(f.type[i], types) << what;
    ASSERT_TRUE(f.x[i] >= f.lo[0] && f.x[i] <= f.hi[0]) << what << " particle " << i + 1 << " x " << f.x[i];
    ASSERT_TRUE(f.y[i] >= f.lo[1] && f.y[i] <= f.hi[1]) << what << " particle " << i + 1 << " y " << f.y[i];
    ASSERT_TRUE(f.z[i] >= f.lo[2] && f.z[i] <= f.hi[2]) << what << " particle " << i + 1 << " z " << f.z[i];
  }
}

// Fraction of empty cells of a grid with cell size `cell` over [lo, hi] (only cells fully inside).
double empty_fraction(const Frame& f, const double lo[3], const double hi[3], double cell) {
  int64_t n[3];
  for (int a = 0; a < 3; ++a) n[a] = static_cast<int64_t>(std::floor((hi[a] - lo[a]) / cell));
  std::vector<uint32_t> occ(static_cast<size_t>(n[0] * n[1] * n[2]), 0);
  for (size_t i = 0; i < f.x.size(); ++i) {
    const double p[3] = {f.x[i], f.y[i], f.z[i]};
    int64_t c[3];
    bool in = true;
    for (int a = 0; a < 3; ++a) {
      const double u = (p[a] - lo[a]) / cell;
      c[a] = static_cast<int64_t>(std::floor(u));
      if (u < 0 || c[a] >= n[a]) in = false;
    }
    if (in) ++occ[static_cast<size_t>((c[2] * n[1] + c[1]) * n[0] + c[0])];
  }
  return static_cast<double>(std::count(occ.begin(), occ.end(), 0u)) / static_cast<double>(occ.size());
}

}  // namespace

TEST(Synth, ExactCountAndValidDumpForEveryScene) {
  for (Scene s : kScenes) {
    for (uint64_t n : {uint64_t{1}, uint64_t{2}, uint64_t{7}, uint64_t{100}, uint64_t{1001}, uint64_t{54321}}) {
      Written w = make(s, n);
      ASSERT_EQ(w.frames.size(), 1u);
      const std::string what = std::string(mds::synth::scene_name(s)) + " N=" + std::to_string(n);
      expect_valid_frame(w.frames[0], n, w.summary.types, what);
      uint64_t sum = 0;
      for (const auto& [name, c] : w.summary.parts) sum += c;
      EXPECT_EQ(sum, n) << what;
    }
  }
}

TEST(Synth, SameSeedSameBytesDifferentSeedDifferentBytes) {
  for (Scene s : kScenes) {
    Written a = make(s, 30000, 5, "a.dump");
    Written b = make(s, 30000, 5, "b.dump");
    Written c = make(s, 30000, 6, "c.dump");
    const std::string ta = read_file(a.path), tb = read_file(b.path), tc = read_file(c.path);
    EXPECT_EQ(ta, tb) << mds::synth::scene_name(s);
    EXPECT_NE(ta, tc) << mds::synth::scene_name(s);
  }
}

TEST(Synth, OutputDoesNotDependOnThreadCount) {
  for (Scene s : {Scene::porous, Scene::shell, Scene::gas}) {
    Written a = make(s, 200000, 3, "t1.dump", 1, 0, 1);
    Written b = make(s, 200000, 3, "t3.dump", 1, 0, 3);
    EXPECT_EQ(read_file(a.path), read_file(b.path)) << mds::synth::scene_name(s);
  }
}

TEST(Synth, GzipOutputDecompressesToThePlainDump) {
  Written plain = make(Scene::ablation, 150000, 2, "plain.dump");
  Written gz = make(Scene::ablation, 150000, 2, "packed.dump.gz");
  const std::string t = read_file(plain.path);
  EXPECT_EQ(read_file(gz.path), t);
  EXPECT_LT(fs::file_size(gz.path), t.size() / 2);
  unsigned char magic[2] = {0, 0};
  std::ifstream in(gz.path, std::ios::binary);
  in.read(reinterpret_cast<char*>(magic), 2);
  EXPECT_EQ(magic[0], 0x1f);
  EXPECT_EQ(magic[1], 0x8b);
}

TEST(Synth, FramesCarrySmallDisplacements) {
  Written one = make(Scene::porous, 20000, 4, "one.dump");
  Written three = make(Scene::porous, 20000, 4, "three.dump", 3);
  ASSERT_EQ(three.frames.size(), 3u);
  // Frame 0 of a multi-frame file equals the single-frame file.
  const std::string t1 = read_file(one.path), t3 = read_file(three.path);
  EXPECT_EQ(t3.substr(0, t1.size()), t1);
  std::set<int64_t> steps;
  for (const Frame& f : three.frames) {
    expect_valid_frame(f, 20000, 2, "porous frames");
    steps.insert(f.timestep);
  }
  EXPECT_EQ(steps.size(), 3u);
  double max_d = 0;
  size_t moved = 0;
  for (size_t i = 0; i < 20000; ++i) {
    EXPECT_EQ(three.frames[0].type[i], three.frames[2].type[i]);
    const double d = std::hypot(three.frames[2].x[i] - three.frames[0].x[i], three.frames[2].y[i] - three.frames[0].y[i],
                                three.frames[2].z[i] - three.frames[0].z[i]);
    max_d = std::max(max_d, d);
    if (d > 0) ++moved;
  }
  EXPECT_LT(max_d, 0.6);     // thermal motion only: bounded, well below the spacing of 1
  EXPECT_GT(moved, 19000u);  // but (almost) every atom moves

  // The ablation plume expands: the box grows and every frame stays inside its box.
  Written abl = make(Scene::ablation, 30000, 4, "abl3.dump", 3);
  ASSERT_EQ(abl.frames.size(), 3u);
  EXPECT_GT(abl.frames[2].hi[2], abl.frames[0].hi[2]);
  double top0 = 0, top2 = 0;
  for (size_t i = 0; i < 30000; ++i) {
    top0 = std::max(top0, abl.frames[0].z[i]);
    top2 = std::max(top2, abl.frames[2].z[i]);
  }
  EXPECT_GT(top2, top0);
  for (const Frame& f : abl.frames) expect_valid_frame(f, 30000, 2, "ablation frames");
}

TEST(Synth, TypesOption) {
  Written six = make(Scene::porous, 30000, 1, "types6.dump", 1, 6);
  std::set<int> seen(six.frames[0].type.begin(), six.frames[0].type.end());
  EXPECT_EQ(seen, (std::set<int>{1, 2, 3, 4, 5, 6}));
  Written single = make(Scene::shell, 30000, 1, "types1.dump", 1, 1);
  seen = std::set<int>(single.frames[0].type.begin(), single.frames[0].type.end());
  EXPECT_EQ(seen, (std::set<int>{1}));
  Written natural = make(Scene::shell, 30000, 1, "types4.dump");
  seen = std::set<int>(natural.frames[0].type.begin(), natural.frames[0].type.end());
  EXPECT_EQ(seen, (std::set<int>{1, 2, 3, 4}));
}

TEST(Synth, PorousHasVoidsAblationBlockIsSolid) {
  Written p = make(Scene::porous, 120000, 1);
  const Frame& f = p.frames[0];
  const double width = p.summary.geometry.at("width");
  const double lo[3] = {0.5, 0.5, 0.5}, hi[3] = {width - 0.5, width - 0.5, p.summary.geometry.at("height") - 0.5};
  const double porous_empty = empty_fraction(f, lo, hi, 2.0);

  Written a = make(Scene::ablation, 120000, 1);
  const double aw = a.summary.geometry.at("width");
  const double alo[3] = {0.5, 0.5, 1.0}, ahi[3] = {aw - 0.5, aw - 0.5, a.summary.geometry.at("surface_z") - 3.0};
  const double solid_empty = empty_fraction(a.frames[0], alo, ahi, 2.0);
  EXPECT_LT(solid_empty, 0.005);
  EXPECT_GT(porous_empty, 0.08);
  // Dense FCC between the voids: nearly the full lattice density in occupied space.
  double vol = 1;
  for (int k = 0; k < 3; ++k) vol *= hi[k] - lo[k];
  EXPECT_LT(static_cast<double>(f.n) / vol, 1.45);
  EXPECT_GT(static_cast<double>(f.n) / vol, 0.6);
}

TEST(Synth, AblationDenseBottomSparseExpandingPlume) {
  Written w = make(Scene::ablation, 200000, 1);
  const Frame& f = w.frames[0];
  const double width = w.summary.geometry.at("width"), surface = w.summary.geometry.at("surface_z");
  const double plume = w.summary.geometry.at("plume_height");
  auto density = [&](double z0, double z1) {
    size_t c = 0;
    for (size_t i = 0; i < f.n; ++i) c += (f.z[i] >= z0 && f.z[i] < z1) ? 1 : 0;
    return static_cast<double>(c) / (width * width * (z1 - z0));
  };
  const double bulk = density(2.0, surface - 4.0);
  EXPECT_NEAR(bulk, std::sqrt(2.0), 0.1);  // FCC with nearest-neighbour distance 1
  const double low = density(surface + 1.0, surface + plume / 6), high = density(surface + plume / 2, surface + plume);
  EXPECT_LT(low, 0.25 * bulk);
  EXPECT_GT(low, 3.0 * high);  // density falls off with height
  EXPECT_GT(high, 0.0);
  // Both phases present.
  std::set<int> seen(f.type.begin(), f.type.end());
  EXPECT_EQ(seen, (std::set<int>{1, 2}));
}

TEST(Synth, ShellIsHollowWithSpikes) {
  Written w = make(Scene::shell, 150000, 1);
  const Frame& f = w.frames[0];
  const double ri = w.summary.geometry.at("r_inner"), ro = w.summary.geometry.at("r_outer");
  const double rmax = w.summary.geometry.at("max_radius");
  double c[3] = {0, 0, 0};
  for (size_t i = 0; i < f.n; ++i) { c[0] += f.x[i]; c[1] += f.y[i]; c[2] += f.z[i]; }
  for (double& v : c) v /= static_cast<double>(f.n);
  size_t centre = 0, band = 0, outside = 0;
  double far = 0;
  for (size_t i = 0; i < f.n; ++i) {
    const double r = std::hypot(f.x[i], f.y[i], f.z[i]);
    far = std::max(far, r);
    if (r < 0.4 * ri) ++centre;
    if (r >= ri - 0.3 && r <= ro + 0.3) ++band;
    if (r > ro + 3.0) ++outside;
  }
  EXPECT_LT(std::hypot(c[0], c[1], c[2]), 0.1 * ro);  // centred
  EXPECT_EQ(centre, 0u);                              // hollow
  EXPECT_GT(static_cast<double>(band) / f.n, 0.6);   // mostly a thin shell
  EXPECT_GT(static_cast<double>(outside) / f.n, 0.05);  // spikes
  EXPECT_LE(far, rmax + 0.5);
  EXPECT_LT(ro - ri, 0.15 * ro);
}

TEST(Synth, GasIsSparseAndClustered) {
  Written w = make(Scene::gas, 30000, 1);
  const Frame& f = w.frames[0];
  const double box = f.hi[0] - f.lo[0];
  EXPECT_NEAR(f.n / (box * box * box), 0.02, 0.002);
  // Fraction of atoms with a neighbour closer than 1.2 (cell list); Poisson gas: about 14%.
  const double cut = 1.2;
  const int64_t nc = static_cast<int64_t>(box / cut);
  std::unordered_map<int64_t, std::vector<size_t>> cells;
  auto key = [&](int64_t a, int64_t b, int64_t c) { return (a * (nc + 2) + b) * (nc + 2) + c; };
  auto cell_of = [&](double v) { return std::min<int64_t>(nc - 1, static_cast<int64_t>((v - f.lo[0]) / box * nc)); };
  for (size_t i = 0; i < f.n; ++i) cells[key(cell_of(f.x[i]), cell_of(f.y[i]), cell_of(f.z[i]))].push_back(i);
  size_t with_neighbour = 0;
  for (size_t i = 0; i < f.n; ++i) {
    const int64_t cx = cell_of(f.x[i]), cy = cell_of(f.y[i]), cz = cell_of(f.z[i]);
    bool found = false;
    for (int64_t dx = -1; dx <= 1 && !found; ++dx)
      for (int64_t dy = -1; dy <= 1 && !found; ++dy)
        for (int64_t dz = -1; dz <= 1 && !found; ++dz) {
          auto it = cells.find(key(cx + dx, cy + dy, cz + dz));
          if (it == cells.end()) continue;
          for (size_t j : it->second) {
            if (j != i && std::hypot(f.x[i] - f.x[j], f.y[i] - f.y[j], f.z[i] - f.z[j]) < cut) { found = true; break; }
          }
        }
    with_neighbour += found ? 1 : 0;
  }
  EXPECT_GT(static_cast<double>(with_neighbour) / f.n, 0.3);
}

TEST(Synth, ProjectReaderReadsTheDump) {
  Written w = make(Scene::shell, 80000, 9, "reader.dump.gz");
  auto reader = mds::open_reader(w.path, mds::ReaderOptions{});
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  EXPECT_EQ((*reader)->info().particle_count, 80000u);
  mds::ParticleBatch batch;
  size_t k = 0;
  double max_err = 0;
  for (;;) {
    auto got = (*reader)->read(batch, 7000);
    ASSERT_TRUE(got.ok()) << got.error().message;
    if (*got == 0) break;
    for (size_t i = 0; i < batch.size(); ++i, ++k) {
      ASSERT_LT(k, 80000u);
      EXPECT_EQ(batch.type[i], w.frames[0].type[k]);
      max_err = std::max({max_err, std::fabs(batch.x[i] - w.frames[0].x[k]), std::fabs(batch.y[i] - w.frames[0].y[k]),
                          std::fabs(batch.z[i] - w.frames[0].z[k])});
    }
  }
  EXPECT_EQ(k, 80000u);
  EXPECT_LT(max_err, 1e-9);
}

TEST(Synth, CommandLine) {
  const fs::path out = temp_dir() / "cli.dump";
  const std::string bin = MDSTREAM_BIN;
  std::string cmd = bin + " synth --scene gas -n 5k --seed 3 -o " + out.string() + " --quiet";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::vector<Frame> frames;
  ASSERT_EQ(parse_dump(read_file(out), frames), "");
  ASSERT_EQ(frames.size(), 1u);
  expect_valid_frame(frames[0], 5000, 2, "cli");

  const fs::path bad = temp_dir() / "bad.dump";
  for (const std::string args : {" synth --scene nope -o ", " synth --scene gas -n 10x -o ", " synth --scene gas -n 0 -o ",
                                 " synth --scene gas --frames 0 -o "}) {
    cmd = bin + args + bad.string() + " 2>/dev/null";
    EXPECT_NE(std::system(cmd.c_str()), 0) << cmd;
    EXPECT_FALSE(fs::exists(bad)) << cmd;
  }
  // No temporary files left behind in the output folder.
  for (const auto& e : fs::directory_iterator(temp_dir())) {
    EXPECT_EQ(e.path().string().find(".tmp-"), std::string::npos) << e.path();
  }
}
