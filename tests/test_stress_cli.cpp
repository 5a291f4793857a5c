// `mdstream stress` (issue 4): the built CLI end to end on a real synth -> convert store streamed
// through the real renderer (headless Vulkan) with each cache policy, a camera path file, and its
// usage and input errors. No timing is asserted. The report logic on constructed inputs:
// test_stress_report.cpp.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli/vulkan/stress_report.h"
#include "store/store_reader.h"

namespace fs = std::filesystem;
using namespace mds;
using namespace mds::cli::stress;

// ---------------------------------------------------------------------------------------------
// The CLI end to end
// ---------------------------------------------------------------------------------------------

namespace {

std::string stderr_path() { return "/tmp/mds_stress_cli_err." + std::to_string(::getpid()) + ".txt"; }
std::string stdout_path() { return "/tmp/mds_stress_cli_out." + std::to_string(::getpid()) + ".txt"; }

int run(const std::string& args) {
  std::string cmd = std::string(MDSTREAM_BIN) + " " + args + " >" + stdout_path() + " 2>" + stderr_path();
  int r = std::system(cmd.c_str());
  return WIFEXITED(r) ? WEXITSTATUS(r) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), {});
}
std::string last_stderr() { return slurp(stderr_path()); }
std::string last_stdout() { return slurp(stdout_path()); }

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cur += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cur += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

class StressCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mds_stress_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    ASSERT_EQ(run("synth --scene porous --particles 100000 -q -o " + (dir_ / "p.lammpstrj").string()), 0)
        << last_stderr();
    // Small nodes: ~100 of them, so that a budget of a fraction of the store holds several.
    ASSERT_EQ(run("convert " + (dir_ / "p.lammpstrj").string() + " --node-size 1000 -o " + store()), 0)
        << last_stderr();
    fs::remove(dir_ / "p.lammpstrj");
  }
  static void TearDownTestSuite() {
    fs::remove_all(dir_);
    fs::remove(stderr_path());
    fs::remove(stdout_path());
  }
  static std::string store() { return (dir_ / "p.mds").string(); }
  static std::string small() { return " --width 160 --height 120 -q "; }
  static fs::path dir_;

  // Checks every relation between the report's fields that holds for any run.
  static void check_report(const nlohmann::json& j, uint64_t budget) {
    const uint64_t hits = j["cache_hits"], misses = j["cache_misses"];
    EXPECT_GT(hits + misses, 0u);
    const double rate = j["hit_rate"];
    EXPECT_GE(rate, 0.0);
    EXPECT_LE(rate, 1.0);
    EXPECT_DOUBLE_EQ(rate, double(hits) / double(hits + misses));
    EXPECT_EQ(j["gpu_budget_bytes"].get<uint64_t>(), budget);
    EXPECT_LE(j["pool_bytes"].get<uint64_t>(), budget);
    EXPECT_GT(j["pool_bytes"].get<uint64_t>(), 0u);
    EXPECT_LE(j["gpu_peak_bytes"].get<uint64_t>(), j["gpu_budget_bytes"].get<uint64_t>());
    const uint64_t store_bytes = j["store_payload_bytes"], frames_total = j["frames_total"];
    EXPECT_EQ(j["store_file_bytes"].get<uint64_t>(), fs::file_size(store()));
    EXPECT_LT(store_bytes, j["store_file_bytes"].get<uint64_t>());
    EXPECT_GT(j["bytes_read"].get<uint64_t>(), 0u);
    EXPECT_LE(j["bytes_read"].get<uint64_t>(), store_bytes * frames_total);
    EXPECT_EQ(j["frames_total"].get<uint64_t>(),
              j["frames"].get<uint64_t>() + j["settle_frames_run"].get<uint64_t>() +
                  j["converged_frames_run"].get<uint64_t>());
    const uint64_t nodes = j["nodes"];
    EXPECT_LE(j["nodes_never_loaded"].get<uint64_t>(), nodes);
    EXPECT_GE(j["nodes_loaded"].get<uint64_t>(), nodes - j["nodes_never_loaded"].get<uint64_t>());
    uint64_t ev = 0;
    for (const char* c : {"O", "M", "L", "P"}) ev += j["evictions"][c].get<uint64_t>();
    EXPECT_LE(ev, j["nodes_loaded"].get<uint64_t>());
    for (const char* k : {"frame_ms", "streaming_frame_ms", "convergence_ms"}) {
      EXPECT_LE(j[k]["p50"].get<double>(), j[k]["p99"].get<double>() + 1e-9) << k;
      EXPECT_LE(j[k]["p99"].get<double>(), j[k]["max"].get<double>() + 1e-9) << k;
    }
    EXPECT_EQ(j["frame_ms"]["frames"].get<uint64_t>(), j["frames"].get<uint64_t>());
    // The offline bound replays exactly the requests the online cache counted.
    const auto& b = j["bound"];
    EXPECT_EQ(b["budget_bytes"].get<uint64_t>(), j["pool_bytes"].get<uint64_t>());
    for (const char* s : {"belady", "belady_bypass", "lru", "fifo"}) {
      EXPECT_EQ(b[s]["requests"].get<uint64_t>(), hits + misses) << s;
      EXPECT_GE(b[s]["hit_rate"].get<double>(), 0.0) << s;
      EXPECT_LE(b[s]["hit_rate"].get<double>(), 1.0) << s;
      EXPECT_LE(b[s]["hits"].get<uint64_t>(), b[s]["requests"].get<uint64_t>()) << s;
    }
    EXPECT_GE(j["views_held"].get<uint64_t>(), 1u);
    EXPECT_EQ(j["views"].size(), j["views_held"].get<size_t>());
    EXPECT_LE(j["views_converged"].get<uint64_t>(), j["views_held"].get<uint64_t>());
    for (const auto& v : j["views"]) {
      if (v["converged"].get<bool>()) {
        EXPECT_GE(v["frames_to_converge"].get<uint64_t>(), 1u);
        EXPECT_LE(v["frames_to_converge"].get<uint64_t>(), v["frames"].get<uint64_t>());
      }
    }
    EXPECT_TRUE(j["errors"].empty());
  }
};
fs::path StressCli::dir_;

}  // namespace

TEST_F(StressCli, EveryPolicyOnJumpsWritesConsistentJsonAndCsv) {
  const uint64_t store_bytes = fs::file_size(store());
  const uint64_t budget = store_bytes / 4;
  for (const char* policy : {"occlusion", "lru", "fifo"}) {
    SCOPED_TRACE(policy);
    const fs::path js = dir_ / (std::string(policy) + ".json"), csv = dir_ / (std::string(policy) + ".csv"),
                   nlog = dir_ / (std::string(policy) + "_nodes.csv");
    ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) + " --path jumps --frames 24 --policy " +
                  policy + " --settle-frames 40 --json " + js.string() + " --csv " + csv.string() + " --node-log " +
                  nlog.string() + small()),
              0)
        << last_stderr();
    std::ifstream f(js);
    const auto j = nlohmann::json::parse(f);
    // --node-log: a row per node; what the path loaded, re-read included, adds up to the report.
    {
      std::istringstream log(slurp(nlog));
      std::string line;
      ASSERT_TRUE(std::getline(log, line));
      const auto head = split_csv_line(line);
      ASSERT_EQ(head.size(), 13u);
      EXPECT_EQ(head[6], "requests");
      EXPECT_EQ(head[7], "reads");
      uint64_t rows = 0, loaded = 0, requests = 0, reads = 0, read_bytes = 0;
      while (std::getline(log, line)) {
        const auto c = split_csv_line(line);
        ASSERT_EQ(c.size(), 13u) << line;
        ++rows;
        loaded += c[9] == "1";
        requests += std::stoull(c[6]);
        reads += std::stoull(c[7]);
        read_bytes += std::stoull(c[7]) * std::stoull(c[2]);
        if (c[9] == "1") {
          EXPECT_NE(c[7], "0") << "node " << c[0] << " loaded without a read";
        }
      }
      EXPECT_EQ(rows, j["nodes"].get<uint64_t>());
      EXPECT_EQ(loaded, rows - j["nodes_never_loaded"].get<uint64_t>());
      EXPECT_EQ(read_bytes, j["bytes_read"].get<uint64_t>());
      EXPECT_GE(reads, j["nodes_loaded"].get<uint64_t>()) << "every upload was read";
      EXPECT_GE(requests, reads);
      EXPECT_GT(reads, loaded) << "jumps at a quarter of the store read some nodes again";
    }
    EXPECT_EQ(j["policy"].get<std::string>(), policy);
    EXPECT_EQ(j["path"].get<std::string>(), "jumps");
    EXPECT_EQ(j["frames"].get<uint32_t>(), 24u);
    EXPECT_EQ(j["width"].get<uint32_t>(), 160u);
    EXPECT_EQ(j["views_held"].get<uint32_t>(), 8u);  // a cut every 24 / 8 frames
    check_report(j, budget);

    // CSV: header + one row, the same values as the JSON.
    std::istringstream lines(slurp(csv));
    std::string header, row, extra;
    ASSERT_TRUE(std::getline(lines, header));
    ASSERT_TRUE(std::getline(lines, row));
    EXPECT_FALSE(std::getline(lines, extra) && !extra.empty());
    const auto keys = split_csv_line(header), values = split_csv_line(row);
    ASSERT_EQ(keys.size(), values.size());
    std::map<std::string, std::string> m;
    for (size_t i = 0; i < keys.size(); ++i) m[keys[i]] = values[i];
    for (const char* k : {"hit_rate", "bytes_read", "bytes_uploaded", "evictions_O", "evictions_M", "evictions_L",
                          "evictions_P", "upload_stalls", "nodes_never_loaded", "frame_ms_p50", "frame_ms_p99",
                          "frame_ms_max", "bound_belady_hit_rate", "bound_lru_hit_rate", "bound_fifo_hit_rate",
                          "gpu_budget_bytes", "gpu_peak_bytes", "convergence_ms_p50", "final_view_converged"})
      EXPECT_TRUE(m.count(k)) << k;
    EXPECT_EQ(m["policy"], policy);
    EXPECT_DOUBLE_EQ(std::stod(m["hit_rate"]), j["hit_rate"].get<double>());
    EXPECT_EQ(std::stoull(m["bytes_read"]), j["bytes_read"].get<uint64_t>());
    EXPECT_DOUBLE_EQ(std::stod(m["bound_belady_hit_rate"]), j["bound"]["belady"]["hit_rate"].get<double>());
    EXPECT_EQ(std::stoull(m["evictions_O"]), j["evictions"]["O"].get<uint64_t>());
  }
  // The table on stdout.
  const std::string out = last_stdout();
  EXPECT_NE(out.find("hit rate (online)"), std::string::npos) << out;
  EXPECT_NE(out.find("Belady"), std::string::npos) << out;
}

TEST_F(StressCli, PerFrameSampleRoutesFollowAForcedRoute) {
  // per_frame.sample_route records what each frame's occlusion sampling ran: with the route
  // forced (MDSTREAM_CULL_SAMPLE) every pass takes it and nothing is probed.
  const uint64_t budget = fs::file_size(store()) / 4;
  for (const char* route : {"raster", "compute"}) {
    SCOPED_TRACE(route);
    const fs::path js = dir_ / (std::string("route_") + route + ".json");
    setenv("MDSTREAM_CULL_SAMPLE", route, 1);
    const int rc = run("stress " + store() + " --gpu-budget " + std::to_string(budget) +
                       " --path flythrough --frames 6 --settle-frames 6 --json " + js.string() + small());
    unsetenv("MDSTREAM_CULL_SAMPLE");
    ASSERT_EQ(rc, 0) << last_stderr();
    std::ifstream f(js);
    const auto j = nlohmann::json::parse(f);
    const auto& routes = j["per_frame"]["sample_route"];
    ASSERT_FALSE(routes.empty());
    uint32_t taken = 0;
    for (size_t i = 0; i < routes.size(); ++i) {
      const std::string other = std::string(route) == "raster" ? "compute" : "raster";
      EXPECT_EQ(routes[i][other].get<uint32_t>(), 0u) << "frame " << i;
      EXPECT_EQ(routes[i]["probe"].get<std::string>(), "") << "frame " << i;
      taken += routes[i][route].get<uint32_t>();
    }
    EXPECT_GE(taken, 6u);  // at least one pass in each moving frame
  }
}

TEST_F(StressCli, ContinuousPathsSettleTheFinalViewAndAcceptSlowDiskOptions) {
  const uint64_t budget = fs::file_size(store()) / 4;
  for (const char* path : {"orbit", "flythrough"}) {
    SCOPED_TRACE(path);
    const fs::path js = dir_ / (std::string(path) + ".json");
    ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) + " --path " + path +
                  " --frames 12 --settle-frames 40 --io-latency-ms 0.5 --io-bandwidth 100MB --io-threads 3 --json " + js.string() +
                  small()),
              0)
        << last_stderr();
    std::ifstream f(js);
    const auto j = nlohmann::json::parse(f);
    check_report(j, budget);
    EXPECT_EQ(j["io"]["bandwidth_bytes_per_s"].get<uint64_t>(), 100000000u);  // MB = 10^6 bytes
    EXPECT_EQ(j["io"]["threads"].get<uint32_t>(), 3u);
    EXPECT_DOUBLE_EQ(j["io"]["latency_ms"].get<double>(), 0.5);
    // Every frame has its own GPU passes, the moving ones too (a new camera used to drop the
    // previous frame's timestamps with the pool: 0 ms on every frame of a fly-through).
    const auto& gpu = j["per_frame"]["gpu_ms"];
    const auto& passes = j["per_frame"]["gpu_passes"];
    ASSERT_EQ(gpu.size(), passes.size());
    // The frame's CPU parts: each within the frame's wall time, the cache's update within step.
    const auto& parts = j["per_frame"]["cpu_parts"];
    const auto& wall = j["per_frame"]["wall_ms"];
    ASSERT_EQ(parts.size(), gpu.size());
    for (size_t i = 0; i < parts.size(); ++i) {
      const double resize = parts[i]["resize"], view = parts[i]["set_view"], step = parts[i]["step"],
                   cache = parts[i]["cache"], finish = parts[i]["finish"];
      EXPECT_GE(resize, 0.0);
      EXPECT_GE(view, 0.0);
      EXPECT_GE(cache, 0.0);
      EXPECT_LE(cache, step) << "frame " << i;
      EXPECT_GT(finish, 0.0) << "frame " << i;
      // The parts tile the frame: [resize] set_view step finish, one clock reading between each.
      EXPECT_NEAR(resize + view + step + finish, wall[i].get<double>(), 1e-6 * wall[i].get<double>()) << "frame " << i;
    }
    for (size_t i = 0; i < gpu.size(); ++i) {
      double sum = 0.0;
      for (const auto& [name, ms] : passes[i].items()) sum += ms.get<double>();
      EXPECT_GT(gpu[i].get<double>(), 0.0) << "frame " << i;
      EXPECT_NEAR(sum, gpu[i].get<double>(), 1e-6 * sum) << "frame " << i;
      if (i > 0 && i < 12) {
        EXPECT_TRUE(passes[i].contains("classify_nodes")) << "frame " << i;  // a culling iteration
        EXPECT_TRUE(passes[i].contains("classify_meshlets")) << "frame " << i;
        // ... of a new view, whose reset is recorded and timed in the frame (CullLoop::prepare_view)
        EXPECT_TRUE(passes[i].contains("view")) << "frame " << i;
      } else if (i >= 12) {
        EXPECT_FALSE(passes[i].contains("view")) << "frame " << i;  // the held view goes on
      }
    }
    // The occlusion sampling passes by route: one pass per iteration while the camera moves
    // (Renderer::set_motion), and the automatic choice probes the other route at least once.
    const auto& routes = j["per_frame"]["sample_route"];
    ASSERT_EQ(routes.size(), gpu.size());
    int probes = 0;
    for (size_t i = 0; i < 12; ++i) {
      EXPECT_EQ(routes[i]["raster"].get<uint32_t>() + routes[i]["compute"].get<uint32_t>(), 1u) << "frame " << i;
      const bool probed = !routes[i]["probe"].get<std::string>().empty();
      probes += probed ? 1 : 0;
      // A moving probe selects 1/16 of the budget (sample_route.h kSampleRouteMovingProbeShare).
      EXPECT_EQ(routes[i]["probe_share"].get<uint32_t>(), probed ? 16u : 0u) << "frame " << i;
      EXPECT_TRUE(routes[i]["compared_ms"].contains("raster") && routes[i]["compared_ms"].contains("compute"));
    }
    EXPECT_GE(probes, 1);
    for (size_t i = 12; i < routes.size(); ++i) {  // at rest: 1/4 to 1/16 (sample_route_probe_share)
      const uint32_t share = routes[i]["probe_share"];
      if (routes[i]["probe"].get<std::string>().empty()) EXPECT_EQ(share, 0u) << "frame " << i;
      else EXPECT_TRUE(share >= 4u && share <= 16u) << "frame " << i << ": " << share;
    }
    // Camera motion is not a held view: only the final camera (held after the path) is one.
    EXPECT_EQ(j["views_held"].get<uint32_t>(), 1u);
    const auto& v = j["final_view"];
    EXPECT_EQ(v["first_frame"].get<uint32_t>(), 11u);
    EXPECT_EQ(v["settle_frames"].get<uint32_t>(), j["settle_frames_run"].get<uint32_t>());
    if (v["converged"].get<bool>()) {
      EXPECT_EQ(j["converged_frames_run"].get<uint32_t>(), 8u);
      EXPECT_FALSE(j["converged_frame_ms"].is_null());
    }
  }
}

// A replayed path tells the cache its next views (--known-path, the default): the fly-through's
// first frame is already a moving view, so its prefetch opens the read window at once (up to the
// pool's room) instead of the few nodes of one wave at rest; without the path the cache learns
// the motion at the second frame.
TEST_F(StressCli, AKnownPathOpensTheReadWindowAtTheFirstFrame) {
  const uint64_t budget = fs::file_size(store()) / 4;
  nlohmann::json j[2];
  for (int known = 0; known < 2; ++known) {
    SCOPED_TRACE(known);
    const fs::path js = dir_ / ("known" + std::to_string(known) + ".json");
    ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) +
                  " --path flythrough --frames 8 --settle-frames 40 --known-path " + (known ? "true" : "false") +
                  " --json " + js.string() + small()),
              0)
        << last_stderr();
    std::ifstream f(js);
    j[known] = nlohmann::json::parse(f);
    check_report(j[known], budget);
    EXPECT_EQ(j[known]["known_path"].get<bool>(), known == 1);
    const auto& reads = j[known]["per_frame"]["reads_requested"];
    ASSERT_EQ(reads.size(), j[known]["frames_total"].get<size_t>());
    uint64_t total = 0;
    for (const auto& r : reads) total += r.get<uint64_t>();
    EXPECT_GE(total, j[known]["nodes_loaded"].get<uint64_t>());  // every load was requested
  }
  const uint32_t first_learned = j[0]["per_frame"]["reads_requested"][0];
  const uint32_t first_known = j[1]["per_frame"]["reads_requested"][0];
  EXPECT_GE(first_learned, 1u);  // a wave at rest
  EXPECT_GT(first_known, first_learned);
}

// A camera that flies into the dense block keeps wanting the nodes around and ahead of it.
// While the camera moves, the cache keeps a node the culling loop found occluded (one iteration
// per moving view is noisy), but only until no iteration has confirmed it for
// --occluded-hold-frames frames: kept for good (before 2026-11-26), the nodes behind the
// block's first layer stayed O after the camera had passed that layer, and from then on
// nothing was wanted (so nothing was read or drawn) until the camera came to rest.
TEST_F(StressCli, FlyingIntoTheBlockKeepsWantingTheNodesAhead) {
  const fs::path cam = dir_ / "fly_in.cam", js = dir_ / "fly_in.json";
  {
    std::ofstream f(cam);  // from 30 units above the +z face to the block's centre, looking -z
    f << "0  25.3 25.2 80  25.3 25.2 20   0 1 0  40 0\n"
         "23 25.3 25.2 24  25.3 25.2 -36  0 1 0  40 0\n";
  }
  const uint64_t budget = fs::file_size(store()) / 4;
  ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) + " --path " + cam.string() +
                " --settle-frames 120 --json " + js.string() + small()),
            0)
      << last_stderr();
  std::ifstream f(js);
  const auto j = nlohmann::json::parse(f);
  check_report(j, budget);
  ASSERT_EQ(j["frames"].get<uint32_t>(), 24u);
  const auto& hits = j["per_frame"]["hits"];
  const auto& misses = j["per_frame"]["misses"];
  uint64_t last = 0;  // demand of the last 4 path frames: the eye inside the block, moving
  for (size_t k = 20; k < 24; ++k) last += hits[k].get<uint64_t>() + misses[k].get<uint64_t>();
  EXPECT_GT(last, 0u);
  EXPECT_TRUE(j["final_view"]["converged"].get<bool>());
}

// --keep-late-arrivals: a read that arrives for a node found occluded meanwhile is placed
// (counted in late_arrivals_kept) or, with false, dropped. --trace writes the demand that the
// offline bounds replay: one row per frame and wanted node, as many as the hits and misses.
TEST_F(StressCli, LateArrivalsAndTheDemandTrace) {
  const uint64_t budget = fs::file_size(store()) / 4;
  for (const bool keep : {true, false}) {
    SCOPED_TRACE(keep);
    const fs::path js = dir_ / "late.json", tr = dir_ / "late.csv";
    ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) +
                  " --path flythrough --frames 16 --settle-frames 40 --keep-late-arrivals " + (keep ? "true" : "false") +
                  " --json " + js.string() + " --trace " + tr.string() + small()),
              0)
        << last_stderr();
    std::ifstream f(js);
    const auto j = nlohmann::json::parse(f);
    check_report(j, budget);
    const uint64_t kept = j["late_arrivals_kept"];
    if (keep)
      EXPECT_LE(kept, j["nodes_loaded"].get<uint64_t>());
    else
      EXPECT_EQ(kept, 0u);

    std::istringstream lines(slurp(tr));
    std::string line;
    ASSERT_TRUE(std::getline(lines, line));
    EXPECT_EQ(line, "frame,node,bytes,hit,belady_hit");
    const size_t frames_total = j["frames_total"];
    std::vector<uint64_t> per_frame(frames_total, 0), hits_per_frame(frames_total, 0);
    uint64_t rows = 0, belady_hits = 0;
    while (std::getline(lines, line)) {
      const auto v = split_csv_line(line);
      ASSERT_EQ(v.size(), 5u) << line;
      const size_t frame = std::stoull(v[0]);
      ASSERT_LT(frame, frames_total) << line;
      EXPECT_LT(std::stoull(v[1]), j["nodes"].get<uint64_t>()) << line;
      EXPECT_GT(std::stoull(v[2]), 0u) << line;
      ASSERT_TRUE(v[3] == "0" || v[3] == "1") << line;
      ASSERT_TRUE(v[4] == "0" || v[4] == "1") << line;
      ++per_frame[frame];
      hits_per_frame[frame] += v[3] == "1";
      belady_hits += v[4] == "1";
      ++rows;
    }
    EXPECT_EQ(rows, j["cache_hits"].get<uint64_t>() + j["cache_misses"].get<uint64_t>());
    // The outcomes add up to the report's: the online cache's per frame, Belady's in all.
    EXPECT_EQ(belady_hits, j["bound"]["belady"]["hits"].get<uint64_t>());
    for (size_t k = 0; k < frames_total; ++k) {
      EXPECT_EQ(per_frame[k], j["per_frame"]["hits"][k].get<uint64_t>() + j["per_frame"]["misses"][k].get<uint64_t>())
          << "frame " << k;
      EXPECT_EQ(hits_per_frame[k], j["per_frame"]["hits"][k].get<uint64_t>()) << "frame " << k;
    }
  }
}

TEST_F(StressCli, DynamicResolutionScalesOnlyMovingFrames) {
  // An unreachable target (1 us: an NVIDIA H200 renders these frames in under 1 ms, so 1 ms was
  // reachable there) drives the moving frames to --min-scale from the first frame after one whose
  // GPU time was at least a third of its wall time (render/frame_pacer.h: below that share the
  // frame is CPU work that a smaller frame does not reduce, and the scale is kept; on lavapipe,
  // which runs the GPU work on the CPU cores, from frame 1); the held final camera (settle
  // frames) renders at full size, and the report stays consistent.
  const uint64_t budget = fs::file_size(store()) / 4;
  const fs::path js = dir_ / "dyn.json";
  ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) +
                " --path flythrough --frames 10 --settle-frames 40 --dynamic-resolution --frame-ms-target 0.001"
                " --min-scale 0.5 --json " + js.string() + small()),
            0)
      << last_stderr();
  std::ifstream f(js);
  const auto j = nlohmann::json::parse(f);
  check_report(j, budget);
  EXPECT_TRUE(j["dynamic_resolution"].get<bool>());
  EXPECT_DOUBLE_EQ(j["frame_ms_target"].get<double>(), 0.001);
  EXPECT_DOUBLE_EQ(j["scale_min"].get<double>(), 0.5);
  const auto& scale = j["per_frame"]["scale"];
  const auto& settle = j["per_frame"]["settle"];
  ASSERT_EQ(scale.size(), settle.size());
  ASSERT_GT(scale.size(), 10u);
  EXPECT_DOUBLE_EQ(scale[0].get<double>(), 1.0);  // no frame time seen yet
  const auto& wall = j["per_frame"]["wall_ms"];
  const auto& gpu = j["per_frame"]["gpu_ms"];
  // With the split (--pace-gpu-time, on by default on GPU devices) the first path frame after a
  // frame whose GPU time was >= 1/3 of it; without it (a CPU device) the whole frame is priced by
  // its pixels and frame 1 scales down, however the load stretched frame 0's CPU parts.
  size_t first = 1;
  if (j["pace_gpu_time"].get<bool>()) {
    first = 10;
    for (size_t i = 1; i < 10 && first == 10; ++i)
      if (3.0 * gpu[i - 1].get<double>() >= wall[i - 1].get<double>()) first = i;
  }
  if (j["device_type"].get<std::string>() == "cpu") {
    EXPECT_FALSE(j["pace_gpu_time"].get<bool>());
  }
  for (size_t i = 1; i < 10; ++i) {
    EXPECT_DOUBLE_EQ(scale[i].get<double>(), i < first ? 1.0 : 0.5) << "path frame " << i << ", first " << first;
  }
  for (size_t i = 10; i < scale.size(); ++i) {
    EXPECT_TRUE(settle[i].get<bool>());
    EXPECT_DOUBLE_EQ(scale[i].get<double>(), 1.0) << "held frame " << i;
  }
  // Without the flag every frame is at full size.
  const fs::path fixed = dir_ / "fixed.json";
  ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) +
                " --path flythrough --frames 4 --settle-frames 0 --json " + fixed.string() + small()),
            0)
      << last_stderr();
  std::ifstream g(fixed);
  const auto k = nlohmann::json::parse(g);
  EXPECT_FALSE(k["dynamic_resolution"].get<bool>());
  for (const auto& v : k["per_frame"]["scale"]) EXPECT_DOUBLE_EQ(v.get<double>(), 1.0);
  // Bad values are usage errors naming the option.
  EXPECT_EQ(run("stress " + store() + " --gpu-budget 1MiB --path orbit --dynamic-resolution --min-scale 0" + small()), 2);
  EXPECT_NE(last_stderr().find("--min-scale"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("stress " + store() + " --gpu-budget 1MiB --path orbit --frame-ms-target -5" + small()), 2);
  EXPECT_NE(last_stderr().find("--frame-ms-target"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("stress " + store() + " --gpu-budget 1MiB --path orbit --pace-gpu-time maybe" + small()), 2);
  EXPECT_NE(last_stderr().find("--pace-gpu-time"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("stress " + store() + " --gpu-budget 1MiB --path orbit --pace-samples maybe" + small()), 2);
  EXPECT_NE(last_stderr().find("--pace-samples"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("stress " + store() + " --gpu-budget 1MiB --path orbit --moving-waste-share 2" + small()), 2);
  EXPECT_NE(last_stderr().find("--moving-waste-share"), std::string::npos) << last_stderr();
  // The report says whether the pacer priced only the GPU time: by default (auto) on a GPU only.
  EXPECT_EQ(j["pace_gpu_time"].get<bool>(), j["device_type"].get<std::string>() != "cpu");
  // ... and whether the moving frames' sampling followed the pixels (--pace-samples, default on).
  EXPECT_TRUE(j["pace_samples"].get<bool>());
  EXPECT_FALSE(k["pace_samples"].get<bool>());  // no pacer at fixed resolution
  const fs::path forced = dir_ / "forced.json";
  ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) +
                " --path flythrough --frames 3 --settle-frames 0 --dynamic-resolution --pace-gpu-time true "
                "--pace-samples false --json " +
                forced.string() + small()),
            0)
      << last_stderr();
  std::ifstream ff(forced);
  const auto forced_json = nlohmann::json::parse(ff);
  EXPECT_TRUE(forced_json["pace_gpu_time"].get<bool>());
  EXPECT_FALSE(forced_json["pace_samples"].get<bool>());
}

TEST_F(StressCli, CameraPathFile) {
  // Two held views with a cut; frames default to the file's frame count.
  const fs::path cam = dir_ / "two_views.cam", js = dir_ / "file.json";
  {
    std::ofstream f(cam);
    f << "# mdstream camera path v1\n"
         "0  25 25 120  25 25 23  0 1 0  40 0\n"
         "9  25 25 120  25 25 23  0 1 0  40 0\n"
         "10 120 25 23  25 25 23  0 1 0  40 0\n"
         "19 120 25 23  25 25 23  0 1 0  40 0\n";
  }
  const uint64_t budget = fs::file_size(store()) / 3;
  ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) + " --path " + cam.string() +
                " --json " + js.string() + small()),
            0)
      << last_stderr();
  std::ifstream f(js);
  const auto j = nlohmann::json::parse(f);
  check_report(j, budget);
  EXPECT_EQ(j["frames"].get<uint32_t>(), 20u);
  EXPECT_EQ(j["path"].get<std::string>(), cam.string());
  ASSERT_EQ(j["views_held"].get<uint32_t>(), 2u);
  EXPECT_EQ(j["views"][0]["first_frame"].get<uint32_t>(), 0u);
  EXPECT_EQ(j["views"][1]["first_frame"].get<uint32_t>(), 10u);
  EXPECT_GE(j["views"][0]["frames"].get<uint32_t>(), 10u);
}

TEST_F(StressCli, HeldDefaultViewFromAColdCache) {
  const fs::path js = dir_ / "view0.json";
  const uint64_t budget = fs::file_size(store()) / 2;
  const fs::path nlog = dir_ / "view0_nodes.csv";
  ASSERT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) +
                " --path view0 --frames 3 --settle-frames 40 --converged-frames 2 --json " + js.string() +
                " --node-log " + nlog.string() + small()),
            0)
      << last_stderr();
  std::ifstream f(js);
  const auto j = nlohmann::json::parse(f);
  check_report(j, budget);
  // --node-log's visible column: the converged final view's visible nodes (empty otherwise).
  if (j["final_view"]["converged"].get<bool>()) {
    std::istringstream log(slurp(nlog));
    std::string line;
    std::getline(log, line);
    uint64_t visible = 0;
    while (std::getline(log, line)) visible += split_csv_line(line).at(4) == "1";  // the visible column
    EXPECT_EQ(visible, j["final_view"]["visible_nodes"].get<uint64_t>());
    EXPECT_GT(visible, 0u);
  }
  EXPECT_EQ(j["views_held"].get<uint32_t>(), 1u);
  const auto& v = j["final_view"];
  EXPECT_EQ(v["first_frame"].get<uint32_t>(), 0u);
  const auto& pf = j["per_frame"];
  ASSERT_EQ(pf["wall_ms"].size(), j["frames_total"].get<size_t>());
  ASSERT_EQ(pf["bytes_read_total"].size(), j["frames_total"].get<size_t>());
  EXPECT_EQ(pf["bytes_read_total"].back().get<uint64_t>(), j["bytes_read"].get<uint64_t>());
  uint64_t hits = 0, misses = 0;
  for (size_t i = 0; i < pf["hits"].size(); ++i) {
    hits += pf["hits"][i].get<uint64_t>();
    misses += pf["misses"][i].get<uint64_t>();
    EXPECT_EQ(pf["view"][i].get<uint32_t>(), 0u);
    if (i > 0) {
      EXPECT_GE(pf["bytes_read_total"][i].get<uint64_t>(), pf["bytes_read_total"][i - 1].get<uint64_t>());
    }
  }
  EXPECT_EQ(hits, j["cache_hits"].get<uint64_t>());
  EXPECT_EQ(misses, j["cache_misses"].get<uint64_t>());
  if (v["converged"].get<bool>()) {
    // From a cold cache everything read before convergence belongs to this view.
    EXPECT_EQ(v["bytes_read_to_converge"].get<uint64_t>(),
              pf["bytes_read_total"][v["frames_to_converge"].get<size_t>() - 1].get<uint64_t>());
    EXPECT_GT(v["wanted_bytes_at_convergence"].get<uint64_t>(), 0u);
  }
  // The held view0 with other wave settings: it converges, within the budget.
  auto held_view0 = [&](const std::string& name, const std::string& options) {
    const fs::path out = dir_ / (name + ".json");
    EXPECT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) + " --path view0 --frames 3 " +
                  options + " --json " + out.string() + small()),
              0)
        << last_stderr();
    std::ifstream in(out);
    const auto rep = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    if (rep.is_discarded()) {
      ADD_FAILURE() << "no report from " << options;
      return rep;
    }
    check_report(rep, budget);
    EXPECT_TRUE(rep["final_view"]["converged"].get<bool>()) << options;
    EXPECT_GT(rep["nodes_loaded"].get<uint64_t>(), 0u);
    return rep;
  };
  held_view0("view0_nowaves", "--settle-frames 120 --wave-settle-frames 0");  // no waves
  // Nodes of the first wave: the reads the first frame that requested any submitted. Planned
  // before anything arrives, so it does not depend on when the reader threads finish (the bytes
  // read by a given frame do: a wave's second read may land a frame later under load).
  auto first_wave = [](const nlohmann::json& rep) -> uint32_t {
    for (const auto& n : rep["per_frame"]["reads_requested"])
      if (n.get<uint32_t>() > 0) return n.get<uint32_t>();
    return 0;
  };
  // Waves of one node without the coverage rule (--wave-nodes 1 --wave-coverage 0): the first
  // wave is exactly one node.
  const auto j1 = held_view0("view0_wave1", "--settle-frames 120 --wave-nodes 1 --wave-coverage 0");
  ASSERT_FALSE(j1.is_discarded());
  EXPECT_EQ(first_wave(j1), 1u);
  // With the coverage rule (default --wave-coverage 1) the wide view's first wave takes the front
  // nodes that cover the image: more than that one node, and the view converges in fewer frames.
  const auto jc = held_view0("view0_wave1_coverage", "--settle-frames 120 --wave-nodes 1");
  ASSERT_FALSE(jc.is_discarded());
  EXPECT_GT(first_wave(jc), 1u);
  EXPECT_LT(jc["final_view"]["frames_to_converge"].get<uint32_t>(), j1["final_view"]["frames_to_converge"].get<uint32_t>());
}

// The close-up (view2) of the dense block: its nearest node is large on screen and dense, so the
// first wave reads it alone (--front-node-alone, default true); without the rule the first wave
// reads --wave-nodes (2) nodes. Both converge.
TEST_F(StressCli, CloseUpReadsTheLargeDenseFrontNodeAlone) {
  const uint64_t budget = fs::file_size(store()) / 4;
  // The nodes the first frame with requests asked for (planned before any read arrives).
  auto first_read = [&](const std::string& options) -> uint32_t {
    const fs::path out = dir_ / "closeup.json";
    EXPECT_EQ(run("stress " + store() + " --gpu-budget " + std::to_string(budget) +
                  " --path view2 --frames 1 --settle-frames 120 " + options + " --json " + out.string() + small()),
              0)
        << last_stderr();
    std::ifstream in(out);
    const auto rep = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    if (rep.is_discarded()) {
      ADD_FAILURE() << "no report from " << options;
      return 0;
    }
    check_report(rep, budget);
    EXPECT_TRUE(rep["final_view"]["converged"].get<bool>()) << options;
    for (const auto& n : rep["per_frame"]["reads_requested"])
      if (n.get<uint32_t>() > 0) return n.get<uint32_t>();
    ADD_FAILURE() << "nothing read with " << options;
    return 0;
  };
  EXPECT_EQ(first_read(""), 1u) << "the front node was not read alone";
  EXPECT_EQ(first_read("--front-node-alone false"), 2u) << "without the rule the first wave reads --wave-nodes 2";
}

TEST_F(StressCli, UsageAndInputErrors) {
  const fs::path js = dir_ / "err.json";
  const std::string base = "stress " + store() + small() + " --json " + js.string() + " ";
  // Unknown path name that is not a file either: usage error naming it.
  EXPECT_EQ(run(base + "--gpu-budget 1MiB --path spiral"), 2);
  EXPECT_NE(last_stderr().find("spiral"), std::string::npos) << last_stderr();
  // Bad budget text.
  EXPECT_EQ(run(base + "--gpu-budget 12parsecs --path orbit"), 2);
  EXPECT_NE(last_stderr().find("--gpu-budget"), std::string::npos) << last_stderr();
  EXPECT_NE(last_stderr().find("12parsecs"), std::string::npos) << last_stderr();
  // Missing required options.
  EXPECT_EQ(run("stress " + store() + " --path orbit"), 2);
  EXPECT_NE(last_stderr().find("--gpu-budget"), std::string::npos) << last_stderr();
  // Bad policy, bad bandwidth, negative latency.
  EXPECT_EQ(run(base + "--gpu-budget 1MiB --path orbit --wave-settle-frames -1"), 2);
  EXPECT_NE(last_stderr().find("--wave-settle-frames"), std::string::npos) << last_stderr();
  EXPECT_EQ(run(base + "--gpu-budget 1MiB --path orbit --wave-nodes 0"), 2);
  EXPECT_NE(last_stderr().find("--wave-nodes"), std::string::npos) << last_stderr();
  EXPECT_EQ(run(base + "--gpu-budget 1MiB --path orbit --wave-coverage -1"), 2);
  EXPECT_NE(last_stderr().find("--wave-coverage"), std::string::npos) << last_stderr();
  EXPECT_EQ(run(base + "--gpu-budget 1MiB --path orbit --policy mru"), 2);
  EXPECT_NE(last_stderr().find("mru"), std::string::npos) << last_stderr();
  EXPECT_EQ(run(base + "--gpu-budget 1MiB --path orbit --io-bandwidth fast"), 2);
  EXPECT_NE(last_stderr().find("--io-bandwidth"), std::string::npos) << last_stderr();
  EXPECT_EQ(run(base + "--gpu-budget 1MiB --path orbit --io-latency-ms -3"), 2);
  EXPECT_NE(last_stderr().find("--io-latency-ms"), std::string::npos) << last_stderr();
  // A malformed camera path file: bad input naming file and line.
  const fs::path cam = dir_ / "bad.cam";
  {
    std::ofstream f(cam);
    f << "0 25 25 120 25 25 23 0 1 0 40 0\n0 25 25 120 25 25 23 0 1 0 40 0\n";
  }
  EXPECT_EQ(run(base + "--gpu-budget 1MiB --path " + cam.string()), 1);
  EXPECT_NE(last_stderr().find(cam.string() + ":2:"), std::string::npos) << last_stderr();
  // A missing store names the file.
  EXPECT_NE(run("stress " + (dir_ / "nope.mds").string() + " --gpu-budget 1MiB --path orbit" + small()), 0);
  EXPECT_NE(last_stderr().find("nope.mds"), std::string::npos) << last_stderr();
  // A budget that cannot hold the largest node: a budget error.
  EXPECT_EQ(run(base + "--gpu-budget 64 --path orbit --frames 2"), 4);
  EXPECT_NE(last_stderr().find("budget"), std::string::npos) << last_stderr();
  // No partial output from any of these.
  EXPECT_FALSE(fs::exists(js));
}
