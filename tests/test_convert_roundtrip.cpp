// End-to-end conversion tests: LAMMPS text dump -> convert -> StoreReader -> decode every
// node -> every input particle is found, within the store's reported maximum error.
// Inputs lie on a lattice of spacing 0.01 (distinct sites), far coarser than the quantization
// step, so a decoded position rounds back to exactly one lattice site.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "convert/converter.h"
#include "convert/spill.h"
#include "store/store_reader.h"
#include "scoped_temp_dir.h"

using namespace mds;
namespace fs = std::filesystem;

namespace {

struct TmpDir : mds::test::ScopedTempDir {
  TmpDir() : ScopedTempDir("mds_convert_rt_") {}
};

struct Particle {
  int32_t type;
  double x, y, z;
  float radius;
};

constexpr double kSpacing = 0.01;

// Distinct lattice sites: a dense block, a sparse gas around it and a small far cluster.
std::vector<Particle> make_particles(size_t n, uint32_t seed, bool with_radius) {
  std::mt19937_64 rng(seed);
  std::set<std::tuple<int64_t, int64_t, int64_t>> used;
  std::vector<Particle> out;
  std::uniform_real_distribution<double> u01(0, 1);
  while (out.size() < n) {
    const double r = u01(rng);
    int64_t ix, iy, iz;
    if (r < 0.7) {  // dense block 20^3
      ix = int64_t(rng() % 2000), iy = int64_t(rng() % 2000), iz = int64_t(rng() % 2000);
    } else if (r < 0.95) {  // gas 100 x 100 x 60
      ix = -4000 + int64_t(rng() % 10000), iy = -4000 + int64_t(rng() % 10000), iz = int64_t(rng() % 6000);
    } else {  // far cluster
      ix = 30000 + int64_t(rng() % 300), iy = 30000 + int64_t(rng() % 300), iz = 500 + int64_t(rng() % 300);
    }
    if (!used.insert({ix, iy, iz}).second) continue;
    const int32_t type = 1 + int32_t(rng() % 3);
    // Written with %.2f and parsed back: use the parsed value as the truth.
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2f", double(ix) * kSpacing);
    const double x = std::strtod(buf, nullptr);
    std::snprintf(buf, sizeof buf, "%.2f", double(iy) * kSpacing);
    const double y = std::strtod(buf, nullptr);
    std::snprintf(buf, sizeof buf, "%.2f", double(iz) * kSpacing);
    const double z = std::strtod(buf, nullptr);
    const float rad = with_radius ? float(0.3 + 0.01 * double(rng() % 50)) : 0.0f;
    out.push_back({type, x, y, z, rad});
  }
  return out;
}

void write_lammps(const fs::path& path, const std::vector<Particle>& ps, bool with_radius, bool append = false) {
  FILE* f = std::fopen(path.c_str(), append ? "a" : "w");
  ASSERT_NE(f, nullptr);
  std::fprintf(f, "ITEM: TIMESTEP\n100\nITEM: NUMBER OF ATOMS\n%zu\nITEM: BOX BOUNDS pp pp pp\n", ps.size());
  std::fprintf(f, "-40 310\n-40 310\n0 60\n");
  std::fprintf(f, with_radius ? "ITEM: ATOMS id type x y z radius\n" : "ITEM: ATOMS id type x y z\n");
  for (size_t i = 0; i < ps.size(); ++i) {
    if (with_radius)
      std::fprintf(f, "%zu %d %.2f %.2f %.2f %.2f\n", i + 1, ps[i].type, ps[i].x, ps[i].y, ps[i].z, ps[i].radius);
    else
      std::fprintf(f, "%zu %d %.2f %.2f %.2f\n", i + 1, ps[i].type, ps[i].x, ps[i].y, ps[i].z);
  }
  std::fclose(f);
}

int run(const std::string& cmd) {
  const int st = std::system(cmd.c_str());
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::vector<fs::path> listing(const fs::path& dir) {
  std::vector<fs::path> v;
  for (const auto& e : fs::directory_iterator(dir)) v.push_back(e.path().filename());
  std::sort(v.begin(), v.end());
  return v;
}

// Decodes the whole store and checks it against the input particles.
void check_store(const fs::path& store_path, const std::vector<Particle>& input, const convert::ConvertOptions& opt,
                 bool with_radius) {
  auto rd = store::StoreReader::open(store_path);
  ASSERT_TRUE(rd.ok()) << rd.error().message;
  const auto& h = (*rd)->header();
  ASSERT_EQ(h.particle_count, input.size());
  EXPECT_LE(h.max_error_over_half_step, 1.0 + 1e-6);
  EXPECT_EQ(h.node_size_max, opt.node_size);
  EXPECT_EQ(h.meshlet_size_max, opt.meshlet_size);
  EXPECT_EQ((h.flags & store::kFlagPerParticleRadius) != 0, with_radius);
  const auto types = (*rd)->types();
  ASSERT_EQ(types.size(), 3u);

  // input: lattice site -> (type, radius)
  std::map<std::tuple<int64_t, int64_t, int64_t>, const Particle*> sites;
  for (const auto& p : input)
    sites[{std::llround(p.x / kSpacing), std::llround(p.y / kSpacing), std::llround(p.z / kSpacing)}] = &p;
  std::set<const Particle*> matched;

  store::NodeData nd;
  std::vector<uint8_t> scratch;
  std::vector<uint64_t> density(size_t(h.density_dims[0]) * h.density_dims[1] * h.density_dims[2], 0);
  uint64_t meshlets = 0;
  double max_err = 0;
  for (uint32_t i = 0; i < (*rd)->nodes().size(); ++i) {
    const auto& e = (*rd)->nodes()[i];
    ASSERT_TRUE((*rd)->read_node(i, nd, scratch).ok());
    ASSERT_EQ(nd.particle_count(), e.particle_count);
    ASSERT_LE(e.particle_count, opt.node_size);
    meshlets += nd.meshlet_size.size();
    uint64_t vsum = 0;
    for (const auto& v : (*rd)->voxels(i)) {
      density[v.voxel] += v.count;
      vsum += v.count;
    }
    EXPECT_EQ(vsum, e.particle_count);
    size_t at = 0;
    for (auto ms : nd.meshlet_size) {
      ASSERT_GE(ms, 1);
      ASSERT_LE(ms, opt.meshlet_size);
      at += ms;
    }
    ASSERT_EQ(at, nd.particle_count());
    for (size_t k = 0; k < nd.particle_count(); ++k) {
      double p[3];
      for (int a = 0; a < 3; ++a) p[a] = e.center_min[a] + double(nd.qpos[3 * k + a]) * store::quant_step(e, a);
      auto it = sites.find({std::llround(p[0] / kSpacing), std::llround(p[1] / kSpacing), std::llround(p[2] / kSpacing)});
      ASSERT_NE(it, sites.end()) << "decoded particle " << p[0] << " " << p[1] << " " << p[2] << " not in the input";
      const Particle* in = it->second;
      EXPECT_TRUE(matched.insert(in).second) << "input particle decoded twice";
      EXPECT_EQ(types[nd.type_index[k]].input_id, in->type);
      const double d[3] = {p[0] - in->x, p[1] - in->y, p[2] - in->z};
      for (int a = 0; a < 3; ++a) max_err = std::max(max_err, std::abs(d[a]));
      if (with_radius) {
        const double r = h.radius_min + nd.radius_q[k] * (double(h.radius_max) - h.radius_min) / 65535.0;
        EXPECT_NEAR(r, in->radius, (double(h.radius_max) - h.radius_min) / 65535.0 + 1e-6);
        EXPECT_LE(in->radius, e.max_radius + 1e-6f);
      }
    }
  }
  EXPECT_EQ(matched.size(), input.size());
  EXPECT_EQ(meshlets, h.meshlet_count);
  EXPECT_LE(max_err, h.max_quantization_error * (1 + 1e-9) + 1e-12);
  EXPECT_GT(h.max_quantization_error, 0.0);
  // the density volume is the sum of the nodes' voxel lists
  const auto counts = (*rd)->density_counts();
  ASSERT_EQ(counts.size(), density.size());
  uint64_t total = 0;
  for (size_t v = 0; v < density.size(); ++v) {
    ASSERT_EQ(counts[v], density[v]);
    total += counts[v];
  }
  EXPECT_EQ(total, input.size());
  for (const auto& t : types) {
    uint64_t n = 0;
    for (const auto& p : input) n += p.type == t.input_id;
    EXPECT_EQ(t.particle_count, n);
  }
}

}  // namespace

TEST(ConvertRoundTrip, InMemoryLammpsDumpDecodesToTheInput) {
  TmpDir td;
  const auto input = make_particles(60000, 1, false);
  write_lammps(td.p / "in.lammpstrj", input, false);
  convert::ConvertOptions opt;
  opt.inputs = {td.p / "in.lammpstrj"};
  opt.output = td.p / "out.mds";
  opt.node_size = 4000;
  opt.radius_by_type = {{2, 0.7f}};
  auto rep = convert::convert(opt);
  ASSERT_TRUE(rep.ok()) << rep.error().message;
  EXPECT_FALSE(rep->spilled);
  EXPECT_EQ(rep->bins, 1u);
  EXPECT_EQ(rep->particles, input.size());
  EXPECT_GT(rep->mean_meshlet_size, 14.0);
  EXPECT_LE(rep->max_error_over_half_step, 1.0 + 1e-6);
  check_store(opt.output, input, opt, false);
  auto rd = store::StoreReader::open(opt.output);
  ASSERT_TRUE(rd.ok());
  for (const auto& t : (*rd)->types()) EXPECT_FLOAT_EQ(t.radius, t.input_id == 2 ? 0.7f : 0.5f);
  EXPECT_GT(rep->meshlet_diag_over_spacing, 0.0);
  // the octree meshlet builder: same particles, same nodes, other meshlets
  opt.output = td.p / "octree.mds";
  opt.meshlet_builder = convert::MeshletBuilderKind::octree;
  auto rep2 = convert::convert(opt);
  ASSERT_TRUE(rep2.ok()) << rep2.error().message;
  EXPECT_EQ(rep2->meshlet_builder, convert::MeshletBuilderKind::octree);
  EXPECT_EQ(rep2->nodes, rep->nodes);
  EXPECT_GT(rep2->mean_meshlet_size, 8.0);
  EXPECT_GT(rep2->meshlet_diag_over_spacing, 0.0);
  check_store(opt.output, input, opt, false);
  EXPECT_EQ(listing(td.p), (std::vector<fs::path>{"in.lammpstrj", "octree.mds", "out.mds"}));
}

TEST(ConvertRoundTrip, BudgetSmallerThanAQuarterOfTheInputSpillsAndBins) {
  TmpDir td;
  const auto input = make_particles(300000, 2, true);
  write_lammps(td.p / "big.lammpstrj", input, true);
  const auto input_bytes = fs::file_size(td.p / "big.lammpstrj");
  convert::ConvertOptions opt;
  opt.inputs = {td.p / "big.lammpstrj"};
  opt.output = td.p / "big.mds";
  opt.node_size = 2000;
  opt.memory_budget = 2u << 20;
  opt.density.target_voxels = 4096;
  ASSERT_LT(opt.memory_budget * 4, input_bytes);
  ASSERT_LT(opt.memory_budget * 3, input.size() * sizeof(convert::SpillRecord));
  auto rep = convert::convert(opt);
  ASSERT_TRUE(rep.ok()) << rep.error().message;
  EXPECT_TRUE(rep->spilled);
  EXPECT_GT(rep->bins, 1u);
  check_store(opt.output, input, opt, true);
  // the same out of core with octree meshlets
  opt.output = td.p / "big-octree.mds";
  opt.meshlet_builder = convert::MeshletBuilderKind::octree;
  auto rep2 = convert::convert(opt);
  ASSERT_TRUE(rep2.ok()) << rep2.error().message;
  EXPECT_TRUE(rep2->spilled);
  EXPECT_EQ(rep2->nodes, rep->nodes);
  check_store(opt.output, input, opt, true);
  // temporaries are gone
  EXPECT_EQ(listing(td.p), (std::vector<fs::path>{"big-octree.mds", "big.lammpstrj", "big.mds"}));
}

TEST(ConvertRoundTrip, SeveralInputsThroughTheCliWithJsonReport) {
  TmpDir td;
  auto all = make_particles(30000, 3, false);
  std::vector<Particle> a(all.begin(), all.begin() + 10000), b(all.begin() + 10000, all.end());
  write_lammps(td.p / "a.dump", a, false);
  write_lammps(td.p / "b.dump", b, false);
  const std::string cmd = std::string(MDSTREAM_BIN) + " convert " + (td.p / "a.dump").string() + " " +
                          (td.p / "b.dump").string() + " -o " + (td.p / "ab.mds").string() +
                          " --node-size 3000 --meshlet-size 32 --meshlet-builder octree --density-res 16x16x8 --threads 3 --quiet "
                          "--json-report " +
                          (td.p / "r.json").string() + " 2>" + (td.p / "err.txt").string();
  ASSERT_EQ(run(cmd), 0);
  std::ifstream ef(td.p / "err.txt");
  std::string err((std::istreambuf_iterator<char>(ef)), {});
  EXPECT_EQ(err, "");  // --quiet
  std::ifstream jf(td.p / "r.json");
  auto j = nlohmann::json::parse(jf);
  EXPECT_EQ(j["particles"].get<uint64_t>(), all.size());
  EXPECT_EQ(j["density_dims"], nlohmann::json::array({16, 16, 8}));
  EXPECT_GT(j["bytes_per_particle"].get<double>(), 0.0);
  EXPECT_GT(j["compression_ratio"].get<double>(), 0.0);
  EXPECT_GT(j["peak_rss_bytes"].get<uint64_t>(), 0u);
  EXPECT_EQ(j["meshlet_builder"], "octree");
  EXPECT_GT(j["meshlet_quality"]["diag_over_spacing"].get<double>(), 0.0);
  EXPECT_NEAR(j["meshlet_quality"]["mean_size"].get<double>(),
              double(all.size()) / j["meshlets"].get<double>(), 1e-9);
  convert::ConvertOptions opt;
  opt.node_size = 3000;
  opt.meshlet_size = 32;
  check_store(td.p / "ab.mds", all, opt, false);
}

TEST(ConvertRoundTrip, PeakMemoryStaysWithinTheBudgetAboveTheProcessBaseline) {
  // One dump, two frames: frame 0 tiny, frame 1 with records 4x the budget. Converting
  // frame 0 gives the process baseline (code, libraries, the reader's file buffer, which is
  // sized by the file); converting frame 1 may add at most the budget, plus the store
  // writer's output buffer (not part of the converter's budget; at most the output size).
  TmpDir td;
  const auto big = make_particles(300000, 5, false);
  write_lammps(td.p / "two.dump", make_particles(500, 4, false), false);
  write_lammps(td.p / "two.dump", big, false, true);
  const std::string bin = MDSTREAM_BIN;
  const std::string common = " -q --memory-budget 2MiB --node-size 2000 --density-res 4096";
  ASSERT_EQ(run(bin + " convert " + (td.p / "two.dump").string() + " --frame 0 -o " + (td.p / "tiny.mds").string() +
                common + " --json-report " + (td.p / "tiny.json").string()),
            0);
  const uint64_t budget = 2u << 20;
  ASSERT_LT(4 * budget, big.size() * sizeof(convert::SpillRecord));
  ASSERT_EQ(run(bin + " convert " + (td.p / "two.dump").string() + " --frame 1 -o " + (td.p / "big.mds").string() +
                common + " --json-report " + (td.p / "big.json").string()),
            0);
  std::ifstream f1(td.p / "tiny.json"), f2(td.p / "big.json");
  const auto j1 = nlohmann::json::parse(f1), j2 = nlohmann::json::parse(f2);
  EXPECT_EQ(j2["particles"].get<uint64_t>(), big.size());
  EXPECT_TRUE(j2["spilled"].get<bool>());
  EXPECT_GT(j2["bins"].get<uint64_t>(), 1u);
  const uint64_t base = j1["peak_rss_bytes"], peak = j2["peak_rss_bytes"];
  const uint64_t writer_buffer = std::min<uint64_t>(8u << 20, fs::file_size(td.p / "big.mds"));
  EXPECT_LE(peak, base + budget + writer_buffer) << "baseline " << base << " peak " << peak;
}
