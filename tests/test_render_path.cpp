// `mdstream render --path` (cli/vulkan/render_path.h): an animation, one image per camera-path
// frame through one renderer. Each frame is the render of its camera alone; streamed, the cache
// stays warm from frame to frame; the output pattern and the option conflicts are usage errors.
#include <gtest/gtest.h>
#include <tinyexr.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "render/camera_path.h"
#include "render/scene.h"
#include "store/store_reader.h"

namespace fs = std::filesystem;
using namespace mds;

namespace {

int run(const std::string& args) { return mds::testing::run_mdstream(args); }
std::string last_stderr() { return mds::testing::cli_stderr(); }
using mds::testing::load_exr;

class RenderPath : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mds_render_path_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    const std::string dump = (dir_ / "s.lammpstrj").string();
    ASSERT_EQ(run("synth --scene shell --particles 20000 -q -o " + dump), 0) << last_stderr();
    ASSERT_EQ(run("convert " + dump + " -q -o " + store()), 0) << last_stderr();
    ASSERT_EQ(run("convert " + dump + " --node-size 2000 -q -o " + (dir_ / "s2k.mds").string()), 0) << last_stderr();
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string store() { return (dir_ / "s.mds").string(); }
  static fs::path dir_;
};
fs::path RenderPath::dir_;

}  // namespace

// Every frame of an orbit is written, the frames differ, and frame k is the image of a render of
// frame k's camera alone (in memory, culled: the culling restarts per frame).
TEST_F(RenderPath, EachFrameIsTheRenderOfItsCamera) {
  const uint32_t W = 64, H = 48, frames = 4;
  const std::string common = fmt::format(" --spp 2 --width {} --height {}", W, H);
  ASSERT_EQ(run("render " + store() + " -o " + (dir_ / "o_%02d.exr").string() + " --path orbit --frames 4" + common +
                " --stats " + (dir_ / "o.json").string()),
            0)
      << last_stderr();
  std::vector<std::vector<float>> img;
  for (uint32_t f = 0; f < frames; ++f) {
    const fs::path p = dir_ / fmt::format("o_{:02}.exr", f);
    ASSERT_TRUE(fs::exists(p)) << p;
    img.push_back(load_exr(p));
    ASSERT_EQ(img.back().size(), size_t(4) * W * H);
  }
  EXPECT_FALSE(fs::exists(dir_ / "o_04.exr"));
  for (uint32_t f = 1; f < frames; ++f) EXPECT_NE(img[f], img[0]) << "frame " << f << " shows frame 0's view";
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(dir_ / "o.json"));
  ASSERT_EQ(j.at("frame_stats").size(), frames);
  EXPECT_EQ(j.at("frame_stats")[2].at("file").get<std::string>(), (dir_ / "o_02.exr").string());
  EXPECT_TRUE(j.at("frame_stats")[2].at("culling_converged").get<bool>());
  for (const auto& r : j.at("frame_stats")) {  // per-pass GPU times of each frame, summed in gpu_ms
    double sum = 0.0;
    for (const auto& [pass, ms] : r.at("pass_ms_median").items()) sum += ms.get<double>();
    EXPECT_TRUE(r.at("pass_ms_median").contains("draw")) << r.dump();
    EXPECT_GT(r.at("gpu_ms").get<double>(), 0.0);
    EXPECT_NEAR(r.at("gpu_ms").get<double>(), sum, 1e-6 * sum);
  }

  auto reader = store::StoreReader::open(store());
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto scene = render::load_scene(**reader);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const render::CameraPath path = render::builtin_path(render::BuiltinPath::orbit, scene->bounds, frames, 40.0,
                                                       double(W) / double(H));
  for (const uint32_t f : {1u, 3u}) {
    const render::Camera c = path.at(f);
    const fs::path single = dir_ / fmt::format("single_{}.exr", f);
    ASSERT_EQ(run(fmt::format("render {} -o {} --camera {},{},{},{},{},{},{},{},{}{}", store(), single.string(), c.eye.x,
                              c.eye.y, c.eye.z, c.target.x, c.target.y, c.target.z, c.up.x, c.up.y, c.up.z, common)),
              0)
        << last_stderr();
    const std::vector<float> ref = load_exr(single);
    ASSERT_EQ(ref.size(), img[f].size());
    double max_diff = 0.0;
    for (size_t i = 0; i < ref.size(); ++i) max_diff = std::max(max_diff, double(std::abs(ref[i] - img[f][i])));
    EXPECT_LE(max_diff, 1e-5) << "frame " << f;
  }
}

// Streamed through a budget that holds the whole store, no node is read twice over the path: the
// counts since the first frame never fall, and end at most at the store's payload bytes and node
// count (a cache made anew per frame would read the nodes again).
TEST_F(RenderPath, StreamedFramesKeepTheCacheWarm) {
  const std::string s2k = (dir_ / "s2k.mds").string();
  const fs::path stats = dir_ / "g.json";
  ASSERT_EQ(run("render " + s2k + " -o " + (dir_ / "g_%d.png").string() +
                " --path jumps --frames 16 --spp 1 --width 48 --height 36 --gpu-budget 64MiB --stats " +
                stats.string()),
            0)
      << last_stderr();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(stats));
  const auto& rows = j.at("frame_stats");
  ASSERT_EQ(rows.size(), 16u);
  uint64_t before = 0;
  for (const auto& r : rows) {
    const uint64_t b = r.at("bytes_read").get<uint64_t>();
    EXPECT_GE(b, before) << r.dump();
    before = b;
  }
  EXPECT_GT(rows[0].at("bytes_read").get<uint64_t>(), 0u);
  auto reader = store::StoreReader::open(s2k);
  ASSERT_TRUE(reader.ok());
  EXPECT_LE(before, (*reader)->header().payload_bytes);
  EXPECT_LE(rows.back().at("nodes_loaded").get<uint64_t>(), (*reader)->nodes().size());
  EXPECT_TRUE(fs::exists(dir_ / "g_15.png"));
}

TEST_F(RenderPath, BadPatternsAndConflictsAreUsageErrors) {
  const std::string base = "render " + store() + " --spp 1 --width 16 --height 16 ";
  for (const char* bad : {"x.png", "x%d%d.png", "x%5d.png", "x%0d.png", "x%s.png", "x%"}) {
    EXPECT_EQ(run(base + "--path orbit -o " + (dir_ / bad).string()), 2) << bad;
    EXPECT_NE(last_stderr().find("an animation (--path, or several frames of a series) writes one file per frame"), std::string::npos) << last_stderr();
  }
  EXPECT_EQ(run(base + "--path orbit --camera 1,2,3,0,0,0 -o " + (dir_ / "c_%d.png").string()), 2);
  EXPECT_NE(last_stderr().find("--path and --camera"), std::string::npos) << last_stderr();
  EXPECT_EQ(run(base + "--path orbit --visible-reference -o " + (dir_ / "c_%d.png").string()), 2);
  EXPECT_EQ(run(base + "--path orbit --node-log " + (dir_ / "c.csv").string() + " -o " + (dir_ / "c_%d.png").string()),
            2);
  EXPECT_NE(last_stderr().find("--node-log ask about one view"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(dir_ / "c.csv"));
  EXPECT_NE(run(base + "--path " + (dir_ / "missing.path").string() + " -o " + (dir_ / "c_%d.png").string()), 0);
  EXPECT_NE(last_stderr().find("missing.path"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(dir_ / "c_0.png"));
  // A path file: its frames (keyframes 0 and 2: three frames).
  const fs::path file = dir_ / "p.path";
  {
    auto reader = store::StoreReader::open(store());
    ASSERT_TRUE(reader.ok());
    auto scene = render::load_scene(**reader);
    ASSERT_TRUE(scene.ok());
    const render::CameraPath orbit = render::builtin_path(render::BuiltinPath::orbit, scene->bounds, 8, 40.0, 1.0);
    std::vector<render::CameraKey> keys = {{0, orbit.at(0)}, {2, orbit.at(4)}};
    ASSERT_TRUE(render::CameraPath(keys).save(file).ok());
  }
  ASSERT_EQ(run(base + "--no-cull --path " + file.string() + " -o " + (dir_ / "k_%d.png").string()), 0)
      << last_stderr();
  EXPECT_TRUE(fs::exists(dir_ / "k_2.png"));
  EXPECT_FALSE(fs::exists(dir_ / "k_3.png"));
}
