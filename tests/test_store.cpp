// Store writer/reader: round trips of synthetic stores, golden bytes of format version 2,
// writer preconditions and temp-file handling, and the `mdstream info` / `export` commands.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include <lz4.h>
#include <nlohmann/json.hpp>

#include "store/file_io.h"
#include "store/hash.h"
#include "store/store_reader.h"
#include "store/store_writer.h"
#include "store_test_helpers.h"

using namespace mds;
using namespace mds::store;
using mds::testing::SynthOptions;
using mds::testing::SynthStore;

namespace {

template <class T>
T load(const std::vector<uint8_t>& b, size_t off) {
  T v;
  std::memcpy(&v, b.data() + off, sizeof(T));
  return v;
}

void expect_store_matches(const StoreReader& r, const SynthStore& s) {
  const FileHeader& h = r.header();
  EXPECT_EQ(std::memcmp(h.magic, kMagic, 8), 0);
  EXPECT_EQ(h.version, kFormatVersion);
  EXPECT_EQ(h.header_bytes, kHeaderBytes);
  EXPECT_EQ(h.flags, s.summary.flags);
  EXPECT_EQ(h.node_size_max, s.summary.node_size_max);
  EXPECT_EQ(h.meshlet_size_max, s.summary.meshlet_size_max);
  EXPECT_EQ(h.node_count, s.nodes.size());
  EXPECT_EQ(h.particle_count, s.particles);
  EXPECT_EQ(h.type_count, s.summary.types.size());
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(h.bounds_min[a], s.summary.bounds_min[a]);
    EXPECT_EQ(h.bounds_max[a], s.summary.bounds_max[a]);
    EXPECT_EQ(h.density_min[a], s.summary.density_min[a]);
    EXPECT_EQ(h.density_max[a], s.summary.density_max[a]);
    EXPECT_EQ(h.density_dims[a], s.summary.density_dims[a]);
  }
  EXPECT_EQ(h.radius_min, s.summary.radius_min);
  EXPECT_EQ(h.radius_max, s.summary.radius_max);
  EXPECT_EQ(h.max_quantization_error, s.summary.max_quantization_error);
  EXPECT_EQ(h.max_error_over_half_step, s.summary.max_error_over_half_step);
  EXPECT_EQ(r.file_bytes(), std::filesystem::file_size(r.path()));

  ASSERT_EQ(r.types().size(), s.summary.types.size());
  for (size_t t = 0; t < r.types().size(); ++t) {
    EXPECT_EQ(r.types()[t].input_id, s.summary.types[t].input_id);
    EXPECT_EQ(r.types()[t].radius, s.summary.types[t].radius);
    EXPECT_STREQ(r.types()[t].name, s.summary.types[t].name);
    EXPECT_EQ(r.types()[t].particle_count, s.summary.types[t].particle_count) << "type " << t;
  }
  EXPECT_EQ(std::vector<uint32_t>(r.density_counts().begin(), r.density_counts().end()), s.summary.density_counts);

  ASSERT_EQ(r.nodes().size(), s.nodes.size());
  uint64_t first = 0, meshlets = 0, payload = 0, raw = 0;
  NodeData d;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < s.nodes.size(); ++i) {
    const auto& want = s.nodes[i];
    const NodeEntry& e = r.nodes()[i];
    EXPECT_EQ(e.particle_count, want.type_index.size());
    EXPECT_EQ(e.meshlet_count, want.meshlet_size.size());
    EXPECT_EQ(e.first_particle, first);
    EXPECT_EQ(e.first_meshlet, meshlets);
    EXPECT_EQ(e.max_radius, want.max_radius);
    EXPECT_GE(e.payload_raw_bytes, node_payload_fixed_bytes(want.type_index.size(), want.meshlet_size.size(), !want.radius_q.empty()));
    EXPECT_LE(e.payload_raw_bytes, node_payload_max_bytes(want.type_index.size(), want.meshlet_size.size(), !want.radius_q.empty()));
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(e.center_min[a], want.cmin[a]);
      EXPECT_EQ(e.center_max[a], want.cmax[a]);
    }
    auto v = r.voxels(i);
    ASSERT_EQ(v.size(), want.voxels.size());
    for (size_t k = 0; k < v.size(); ++k) {
      EXPECT_EQ(v[k].voxel, want.voxels[k].voxel);
      EXPECT_EQ(v[k].count, want.voxels[k].count);
    }
    first += e.particle_count;
    meshlets += e.meshlet_count;
    payload += e.payload_bytes;
    raw += e.payload_raw_bytes;

    ASSERT_TRUE(r.read_node(i, d, scratch).ok()) << "node " << i;
    EXPECT_EQ(d.qpos, want.qpos);
    EXPECT_EQ(d.type_index, want.type_index);
    EXPECT_EQ(d.radius_q, want.radius_q);
    EXPECT_EQ(d.meshlet_size, want.meshlet_size);
    // Dequantized positions are within the recorded error and within half a step per axis.
    for (size_t k = 0; k < d.particle_count(); ++k)
      for (int a = 0; a < 3; ++a) {
        const double step = quant_step(e, a);
        const double x = e.center_min[a] + d.qpos[3 * k + a] * step;
        const double err = std::abs(x - want.original[k].x[a]);
        EXPECT_LE(err, h.max_quantization_error);
        EXPECT_LE(err, step / 2 * (1 + 1e-9) + 1e-12);
      }
  }
  EXPECT_EQ(h.meshlet_count, meshlets);
  EXPECT_EQ(h.payload_bytes, payload);
  EXPECT_EQ(h.payload_raw_bytes, raw);
}

class RoundTrip : public ::testing::TestWithParam<std::tuple<bool, uint32_t>> {};

TEST_P(RoundTrip, EveryFieldAndPayloadSurvives) {
  auto [radius, grid] = GetParam();
  auto dir = mds::testing::temp_dir("roundtrip");
  SynthOptions o;
  o.seed = 7 + grid;
  o.particles = 5000;
  o.node_size = 300;
  o.meshlet_size = 64;
  o.per_particle_radius = radius;
  o.grid = grid;
  SynthStore s = mds::testing::make_synthetic(o);
  ASSERT_GE(s.nodes.size(), 10u);
  const auto path = dir / "rt.mds";
  ASSERT_EQ(mds::testing::write_store(s, path), "");
  EXPECT_FALSE(std::filesystem::exists(temp_path_for(path)));
  auto r = StoreReader::open(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  expect_store_matches(**r, s);
  std::filesystem::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Store, RoundTrip,
                         ::testing::Combine(::testing::Bool(), ::testing::Values(0u, 1u, 5u)));

TEST(Store, ConcurrentReadsAgree) {
  auto dir = mds::testing::temp_dir("concurrent");
  SynthOptions o;
  o.particles = 20000;
  o.node_size = 500;
  SynthStore s = mds::testing::make_synthetic(o);
  ASSERT_EQ(mds::testing::write_store(s, dir / "c.mds"), "");
  auto r = StoreReader::open(dir / "c.mds");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const StoreReader& reader = **r;
  std::vector<int> failures(4, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      NodeData d;
      std::vector<uint8_t> scratch;
      for (int rep = 0; rep < 3; ++rep)
        for (uint32_t i = 0; i < s.nodes.size(); ++i) {
          uint32_t node = (i * 7 + t) % s.nodes.size();
          if (!reader.read_node(node, d, scratch).ok() || d.qpos != s.nodes[node].qpos) ++failures[t];
        }
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(failures, std::vector<int>(4, 0));
  std::filesystem::remove_all(dir);
}

TEST(Store, EmptyStoreRoundTrips) {
  auto dir = mds::testing::temp_dir("empty");
  auto w = StoreWriter::create(dir / "e.mds");
  ASSERT_TRUE(w.ok());
  StoreSummary sum;
  sum.node_size_max = 100;
  sum.meshlet_size_max = 32;
  ASSERT_TRUE((*w)->finish(sum).ok());
  auto r = StoreReader::open(dir / "e.mds");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ((*r)->header().node_count, 0u);
  EXPECT_EQ((*r)->file_bytes(), kHeaderBytes);
  std::filesystem::remove_all(dir);
}

// ---- golden bytes ------------------------------------------------------------------------
// tests/data/store/golden_v2.mds is the exact output of golden_store() below. If the format
// changes on purpose (with a version bump: version 2 added the occupancy section), regenerate it with
//   MDSTREAM_REGENERATE_GOLDEN=1 build-<name>/tests/test_store --gtest_filter='*Golden*'
// check that the hand-derived payload bytes below still hold, and commit the new file. The bytes also depend on liblz4 producing the same block for the
// same input (true for all 1.9.x releases).
SynthStore golden_store() {
  SynthOptions o;
  o.node_size = 4;
  o.meshlet_size = 3;
  o.types = 2;
  o.grid = 2;
  o.per_particle_radius = true;
  // 7 particles -> 2 nodes (4 + 3), meshlets 3+1 and 3.
  const double xs[7][3] = {{0, 0, 0}, {1, 2, 3}, {2, 1, 0.5}, {3, 3, 3}, {4, 0, 1}, {5, 2, 2}, {6, 1, 3}};
  for (int i = 0; i < 7; ++i)
    o.explicit_particles.push_back({{xs[i][0], xs[i][1], xs[i][2]}, uint8_t(i % 2), float(0.5 + 0.125 * i)});
  return mds::testing::make_synthetic(o);
}

TEST(StoreGolden, BytesMatchCommittedFile) {
  auto dir = mds::testing::temp_dir("golden");
  SynthStore s = golden_store();
  ASSERT_EQ(s.nodes.size(), 2u);
  ASSERT_EQ(mds::testing::write_store(s, dir / "g.mds"), "");
  const auto bytes = mds::testing::read_bytes(dir / "g.mds");
  const std::filesystem::path golden = std::filesystem::path(MDSTREAM_SOURCE_DIR) / "tests/data/store/golden_v2.mds";
  if (std::getenv("MDSTREAM_REGENERATE_GOLDEN")) mds::testing::write_bytes(golden, bytes);
  const auto want = mds::testing::read_bytes(golden);
  ASSERT_FALSE(want.empty()) << "missing " << golden;
  EXPECT_EQ(bytes, want) << "the writer's output differs from " << golden;

  // Header fields at their documented offsets (docs/store-format.md, "Header").
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(want.data()), 8), std::string("MDSTORE\0", 8));
  EXPECT_EQ(load<uint32_t>(want, 8), 2u);     // version
  EXPECT_EQ(load<uint32_t>(want, 12), 512u);  // header_bytes
  EXPECT_EQ(load<uint32_t>(want, 16), 1u);    // flags: per-particle radius
  EXPECT_EQ(load<uint32_t>(want, 20), 4u);    // node_size_max
  EXPECT_EQ(load<uint32_t>(want, 24), 3u);    // meshlet_size_max
  EXPECT_EQ(load<uint32_t>(want, 28), 2u);    // node_count
  EXPECT_EQ(load<uint64_t>(want, 32), 7u);    // particle_count
  EXPECT_EQ(load<uint64_t>(want, 40), 3u);    // meshlet_count
  EXPECT_EQ(load<uint32_t>(want, 48), 2u);    // type_count
  EXPECT_EQ(load<uint32_t>(want, 52), 2u);    // density_dims
  EXPECT_EQ(load<double>(want, 64), 0.0);     // bounds_min.x
  EXPECT_EQ(load<double>(want, 88), 6.0);     // bounds_max.x
  EXPECT_EQ(load<double>(want, 104), 3.0);    // bounds_max.z
  EXPECT_EQ(load<float>(want, 160), 0.5f);    // radius_min
  EXPECT_EQ(load<float>(want, 164), 1.25f);   // radius_max
  const uint64_t payload_bytes = load<uint64_t>(want, 184);
  // Sections: types, directory, voxels, density, back to back after the payloads.
  EXPECT_EQ(load<uint64_t>(want, 200), 512 + payload_bytes);
  EXPECT_EQ(load<uint64_t>(want, 208), 2u * 64);
  EXPECT_EQ(load<uint64_t>(want, 232), 512 + payload_bytes + 128);
  EXPECT_EQ(load<uint64_t>(want, 240), 2u * 112);
  EXPECT_EQ(load<uint64_t>(want, 312), 2u * 2 * 2 * 4);  // sections[3].raw_bytes (density)
  // sections[4]: the occupancy records, 64 bytes per node, end the file.
  EXPECT_EQ(load<uint64_t>(want, 328), load<uint64_t>(want, 296) + load<uint64_t>(want, 304));
  EXPECT_EQ(load<uint64_t>(want, 336), 2u * 64);
  EXPECT_EQ(load<uint64_t>(want, 344), 2u * 64);
  EXPECT_EQ(load<uint64_t>(want, 328) + 128, want.size());
  {
    // Node 0's record: centres (0,0,0) (1,2,3) (2,1,0.5) (3,3,3) in the frame [0,3]^3, each grown
    // by the node's largest radius 0.875, in the box [-0.875, 3.875]^3 of fine cells 0.59375 wide.
    // (0,0,0) reaches fine cells 0..2 per axis: coarse cell 0 is full. (3,3,3) reaches 5..7:
    // coarse cell 63 = (3,3,3) is full, and coarse 42 = (2,2,2) gets fine (5,5,5) = bit 7; (1,2,3)
    // reaches x 1..4, y 3..6, z 5..7, so coarse 42 also gets fine (4,4,5) and (4,5,5) = bits 4, 6.
    const uint64_t occ = load<uint64_t>(want, 328);
    EXPECT_EQ(want[occ + 0], 0xFF);
    EXPECT_EQ(want[occ + 63], 0xFF);
    EXPECT_EQ(want[occ + 42], 0xD0);
  }
  for (size_t i = 360; i < 504; ++i) EXPECT_EQ(want[i], 0) << "reserved byte " << i;
  std::vector<uint8_t> h(want.begin(), want.begin() + 512);
  std::memset(h.data() + 504, 0, 8);
  EXPECT_EQ(load<uint64_t>(want, 504), hash_bytes(h));
  // First directory entry: payload at 512; second follows it.
  const uint64_t dir_off = load<uint64_t>(want, 232);
  EXPECT_EQ(load<uint64_t>(want, dir_off), 512u);
  EXPECT_EQ(load<uint32_t>(want, dir_off + 24), 4u);  // particle_count
  EXPECT_EQ(load<uint32_t>(want, dir_off + 28), 2u);  // meshlet_count
  EXPECT_EQ(load<uint64_t>(want, dir_off + 112), 512u + load<uint32_t>(want, dir_off + 8));
  EXPECT_EQ(load<uint64_t>(want, dir_off + 112 + 32), 4u);  // first_particle of node 1
  EXPECT_EQ(load<uint64_t>(want, 192), uint64_t(load<uint32_t>(want, dir_off + 12)) + load<uint32_t>(want, dir_off + 112 + 12));
  // Node 0's decoded payload, byte by byte as docs/store-format.md ("Node payload") derives it:
  // particles x,y,z = (0,0,0) (1,2,3) (2,1,0.5) (3,3,3) in the frame [0,3]^3, types 0 1 0 1,
  // meshlets 3 + 1, radii 0.5 0.625 0.75 0.875 over [0.5, 1.25].
  {
    const uint32_t raw_bytes = load<uint32_t>(want, dir_off + 12);
    ASSERT_EQ(raw_bytes, 11u * 2 + 2 * 4 + 19);  // fixed arrays + ceil(3 * (3 * 16 + 1) / 8) stream bytes
    std::vector<uint8_t> raw(raw_bytes);
    ASSERT_EQ(LZ4_decompress_safe(reinterpret_cast<const char*>(want.data() + 512), reinterpret_cast<char*>(raw.data()),
                                  int(load<uint32_t>(want, dir_off + 8)), int(raw_bytes)),
              int(raw_bytes));
    EXPECT_EQ(raw[0], 3);                                              // meshlet_size
    EXPECT_EQ(raw[1], 1);
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(load<uint16_t>(raw, 2 + 4 * a), 0u);                   // meshlet_base[a][0]
      EXPECT_EQ(load<uint16_t>(raw, 2 + 4 * a + 2), 65535u);           // meshlet_base[a][1]
    }
    EXPECT_EQ(load<uint16_t>(raw, 14), 16u | 16u << 5 | 16u << 10);   // meshlet_bits[0]
    EXPECT_EQ(load<uint16_t>(raw, 16), 0u);                            // meshlet_bits[1]: one particle
    EXPECT_EQ(raw[18], 0);                                             // meshlet_type_base
    EXPECT_EQ(raw[19], 1);
    EXPECT_EQ(raw[20], 1);                                             // meshlet_type_bits: types 0 1 0
    EXPECT_EQ(raw[21], 0);
    EXPECT_EQ(load<uint16_t>(raw, 22), 0u);                            // radius_q[0] = 0.5 -> 0
    EXPECT_EQ(load<uint16_t>(raw, 28), 32768u);                        // radius_q[3] = 0.875 -> round(0.5 * 65535)
    EXPECT_EQ(load<uint16_t>(raw, 30), 0u);                            // x offsets of meshlet 0: 0,
    EXPECT_EQ(load<uint16_t>(raw, 32), 21845u);                        //   1/3 * 65535,
    EXPECT_EQ(load<uint16_t>(raw, 34), 43690u);                        //   2/3 * 65535
    EXPECT_EQ(load<uint16_t>(raw, 36), 0u);                            // y offsets: 0, 43690, 21845
    EXPECT_EQ(load<uint16_t>(raw, 38), 43690u);
    EXPECT_EQ(load<uint16_t>(raw, 46), 10923u);                        // z of particle 2: 0.5/3 * 65535 rounded
    EXPECT_EQ(raw[48], 0x02);                                          // type offsets 0,1,0 (bits 144..146), padding 0
  }

  auto r = StoreReader::open(golden);
  ASSERT_TRUE(r.ok()) << r.error().message;
  expect_store_matches(**r, s);
  std::filesystem::remove_all(dir);
}

// ---- writer preconditions ------------------------------------------------------------------

TEST(StoreWriter, EncodeRejectsBrokenNodes) {
  SynthOptions o;
  o.particles = 50;
  o.node_size = 50;
  SynthStore s = mds::testing::make_synthetic(o);
  const auto& n = s.nodes[0];
  ASSERT_TRUE(encode_node(mds::testing::node_input(n)).ok());
  {
    auto in = mds::testing::node_input(n);
    in.qpos = in.qpos.subspan(3);
    EXPECT_FALSE(encode_node(in).ok());
  }
  {
    auto in = mds::testing::node_input(n);
    in.type_index = {};
    in.qpos = {};
    in.meshlet_size = {};
    in.voxels = {};
    EXPECT_FALSE(encode_node(in).ok());
  }
  {
    std::vector<uint8_t> ms = n.meshlet_size;
    ms.back() += 1;
    auto in = mds::testing::node_input(n);
    in.meshlet_size = ms;
    auto r = encode_node(in);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, Errc::internal);
    EXPECT_NE(r.error().message.find("meshlet"), std::string::npos);
  }
  {
    std::vector<uint8_t> ms = n.meshlet_size;
    ms.push_back(0);
    auto in = mds::testing::node_input(n);
    in.meshlet_size = ms;
    EXPECT_FALSE(encode_node(in).ok());
  }
  {
    auto in = mds::testing::node_input(n);
    in.center_min[1] = std::nan("");
    EXPECT_FALSE(encode_node(in).ok());
  }
  {
    std::vector<uint16_t> rq(3, 0);
    auto in = mds::testing::node_input(n);
    in.radius_q = rq;
    EXPECT_FALSE(encode_node(in).ok());
  }
  if (n.voxels.size() >= 2) {
    std::vector<VoxelRef> v = n.voxels;
    std::swap(v[0], v[1]);
    auto in = mds::testing::node_input(n);
    in.voxels = v;
    EXPECT_FALSE(encode_node(in).ok());
  }
}

TEST(StoreWriter, AbandonedWriterLeavesNoFiles) {
  auto dir = mds::testing::temp_dir("abandon");
  SynthStore s = mds::testing::make_synthetic({});
  {
    auto w = StoreWriter::create(dir / "a.mds");
    ASSERT_TRUE(w.ok());
    auto enc = encode_node(mds::testing::node_input(s.nodes[0]));
    ASSERT_TRUE(enc.ok());
    ASSERT_TRUE((*w)->append(std::move(enc).value()).ok());
    EXPECT_EQ((*w)->node_count(), 1u);
    EXPECT_GT((*w)->bytes_written(), kHeaderBytes);
    EXPECT_TRUE(std::filesystem::exists(temp_path_for(dir / "a.mds")));
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  std::filesystem::remove_all(dir);
}

TEST(StoreWriter, FinishRejectsInconsistentSummary) {
  auto dir = mds::testing::temp_dir("badsummary");
  SynthStore good = mds::testing::make_synthetic({});
  auto attempt = [&](auto mutate) {
    SynthStore s = good;
    mutate(s.summary);
    std::string err = mds::testing::write_store(s, dir / "b.mds");
    EXPECT_FALSE(std::filesystem::exists(dir / "b.mds"));
    EXPECT_TRUE(std::filesystem::is_empty(dir));
    return err;
  };
  EXPECT_NE(attempt([](StoreSummary& m) { m.types.pop_back(); }), "");                 // type index beyond table
  EXPECT_NE(attempt([](StoreSummary& m) { m.density_counts[0] += 1; }), "");          // density != voxel refs
  EXPECT_NE(attempt([](StoreSummary& m) { m.density_counts.pop_back(); }), "");       // wrong size
  EXPECT_NE(attempt([](StoreSummary& m) { m.node_size_max = 10; }), "");              // nodes too big
  EXPECT_NE(attempt([](StoreSummary& m) { m.meshlet_size_max = 8; }), "");            // meshlets too big
  EXPECT_NE(attempt([](StoreSummary& m) { m.flags = kFlagPerParticleRadius; }), "");  // layout mismatch
  EXPECT_NE(attempt([](StoreSummary& m) { m.flags = 0x80; }), "");                    // unknown flag
  EXPECT_NE(attempt([](StoreSummary& m) { m.bounds_max[2] = std::nan(""); }), "");
  std::filesystem::remove_all(dir);
}

// ---- CLI -------------------------------------------------------------------------------------

struct RunResult {
  int code;
  std::string out;
  std::string err;
};

RunResult run_cli(const std::string& args, const std::filesystem::path& dir) {
  const auto out = dir / "stdout.txt", err = dir / "stderr.txt";
  std::string cmd = std::string(MDSTREAM_BIN) + " " + args + " >" + out.string() + " 2>" + err.string();
  int rc = std::system(cmd.c_str());
  RunResult r;
  r.code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  auto slurp = [](const std::filesystem::path& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

TEST(StoreCli, InfoJsonHasTheKeys) {
  auto dir = mds::testing::temp_dir("cli_info");
  SynthOptions o;
  o.particles = 3000;
  o.node_size = 256;
  SynthStore s = mds::testing::make_synthetic(o);
  ASSERT_EQ(mds::testing::write_store(s, dir / "s.mds"), "");
  auto r = run_cli("info --json --verify " + (dir / "s.mds").string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"particles", "nodes", "meshlets", "bounds_min", "bounds_max", "max_quantization_error",
                          "quantization_step", "density_dims", "file_bytes", "bytes_per_particle", "format_version",
                          "node_size_max", "meshlet_size_max", "types", "payload_bytes", "payload_raw_bytes",
                          "compression_ratio", "occupancy"})
    EXPECT_TRUE(j.contains(key)) << key;
  // Every node occupies some of its 512 cells.
  EXPECT_GT(j["occupancy"]["cells_set_fraction"].get<double>(), 0.0);
  EXPECT_LE(j["occupancy"]["cells_set_fraction"].get<double>(), 1.0);
  EXPECT_LE(j["occupancy"]["full_nodes"].get<uint64_t>(), s.nodes.size());
  EXPECT_EQ(j["particles"].get<uint64_t>(), 3000u);
  EXPECT_EQ(j["nodes"].get<uint64_t>(), s.nodes.size());
  EXPECT_EQ(j["file_bytes"].get<uint64_t>(), std::filesystem::file_size(dir / "s.mds"));
  EXPECT_EQ(j["format_version"].get<int>(), 2);
  EXPECT_EQ(j["bounds_max"][1].get<double>(), s.summary.bounds_max[1]);
  EXPECT_EQ(j["density_dims"][0].get<int>(), 4);
  ASSERT_EQ(j["types"].size(), 3u);
  uint64_t total = 0;
  for (size_t t = 0; t < 3; ++t) {
    EXPECT_EQ(j["types"][t]["name"].get<std::string>(), std::string(s.summary.types[t].name));
    EXPECT_EQ(j["types"][t]["id"].get<int>(), s.summary.types[t].input_id);
    EXPECT_EQ(j["types"][t]["count"].get<uint64_t>(), s.summary.types[t].particle_count);
    total += j["types"][t]["count"].get<uint64_t>();
  }
  EXPECT_EQ(total, 3000u);
  EXPECT_GT(j["compression_ratio"].get<double>(), 0.0);
  EXPECT_GE(j["quantization_step"]["max"].get<double>(), j["quantization_step"]["median"].get<double>());
  EXPECT_GT(j["quantization_step"]["median"].get<double>(), 0.0);

  auto text = run_cli("info " + (dir / "s.mds").string(), dir);
  EXPECT_EQ(text.code, 0);
  EXPECT_NE(text.out.find("particles        3000"), std::string::npos) << text.out;
  std::filesystem::remove_all(dir);
}

TEST(StoreCli, InfoOnMissingOrBadFileFails) {
  auto dir = mds::testing::temp_dir("cli_bad");
  auto r = run_cli("info " + (dir / "nope.mds").string(), dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("nope.mds"), std::string::npos);
  mds::testing::write_bytes(dir / "junk.mds", std::vector<uint8_t>(1000, 7));
  r = run_cli("info --json " + (dir / "junk.mds").string(), dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("magic"), std::string::npos) << r.err;
  std::filesystem::remove_all(dir);
}

TEST(StoreCli, ExportWritesExtendedXyzWithinQuantizationError) {
  for (bool radius : {false, true}) {
    auto dir = mds::testing::temp_dir("cli_export");
    SynthOptions o;
    o.particles = 2000;
    o.node_size = 200;
    o.per_particle_radius = radius;
    SynthStore s = mds::testing::make_synthetic(o);
    ASSERT_EQ(mds::testing::write_store(s, dir / "s.mds"), "");
    auto r = run_cli("export " + (dir / "s.mds").string() + " -o " + (dir / "out.xyz").string(), dir);
    ASSERT_EQ(r.code, 0) << r.err;
    std::ifstream f(dir / "out.xyz");
    std::string line;
    std::getline(f, line);
    EXPECT_EQ(line, "2000");
    std::getline(f, line);
    EXPECT_NE(line.find(radius ? "Properties=species:S:1:pos:R:3:radius:R:1" : "Properties=species:S:1:pos:R:3 "),
              std::string::npos)
        << line;
    const double qerr = s.summary.max_quantization_error;
    const double rstep = (double(s.summary.radius_max) - s.summary.radius_min) / 65535.0;
    size_t count = 0;
    for (const auto& node : s.nodes)
      for (const auto& p : node.original) {
        ASSERT_TRUE(std::getline(f, line));
        std::istringstream ls(line);
        std::string name;
        double x[3];
        ls >> name >> x[0] >> x[1] >> x[2];
        EXPECT_EQ(name, std::string(s.summary.types[p.type].name));
        for (int a = 0; a < 3; ++a) EXPECT_LE(std::abs(x[a] - p.x[a]), qerr) << "particle " << count;
        if (radius) {
          double rr;
          ls >> rr;
          EXPECT_LE(std::abs(rr - p.radius), rstep / 2 + 1e-6) << "particle " << count;
        }
        ++count;
      }
    EXPECT_FALSE(std::getline(f, line));
    EXPECT_EQ(count, 2000u);
    std::filesystem::remove_all(dir);
  }
}

TEST(StoreCli, ExportOfCorruptedPayloadFailsWithoutOutput) {
  auto dir = mds::testing::temp_dir("cli_export_bad");
  SynthOptions o;
  o.particles = 2000;
  o.node_size = 200;
  SynthStore s = mds::testing::make_synthetic(o);
  ASSERT_EQ(mds::testing::write_store(s, dir / "s.mds"), "");
  uint64_t offset = 0;
  {
    auto rd = StoreReader::open(dir / "s.mds");
    ASSERT_TRUE(rd.ok());
    offset = (*rd)->nodes()[5].payload_offset;
  }
  auto bytes = mds::testing::read_bytes(dir / "s.mds");
  bytes[offset + 3] ^= 0x40;
  mds::testing::write_bytes(dir / "s.mds", bytes);
  auto r = run_cli("export " + (dir / "s.mds").string() + " -o " + (dir / "out.xyz").string(), dir);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("node 5 payload at byte " + std::to_string(offset)), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("checksum"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out.xyz"));
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find("out.xyz"), std::string::npos) << entry.path();
  // info --verify finds the same damage; plain info (no payload reads) still works.
  auto v = run_cli("info --verify " + (dir / "s.mds").string(), dir);
  EXPECT_NE(v.code, 0);
  EXPECT_NE(v.err.find("node 5"), std::string::npos) << v.err;
  EXPECT_EQ(run_cli("info " + (dir / "s.mds").string(), dir).code, 0);
  std::filesystem::remove_all(dir);
}

}  // namespace
