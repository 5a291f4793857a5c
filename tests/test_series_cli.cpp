// Store series through the CLI, on LAMMPS' own output (tests/data/lammps/in.lj_small: 5 frames,
// steps 0..200): `convert -o RUN.mds.series` writes one store per frame that equals, byte for
// byte, the store `convert --frame K` writes; per-step files become one series ordered by their
// steps; errors leave nothing behind; `info` lists the frames; `render` of a series frame draws
// exactly what `render` of its store draws with the same camera and colour range, and an
// animation keeps one camera and one colour range over every frame (real Vulkan, lavapipe).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "overlay/axis_tripod.h"
#include "overlay/text_label.h"
#include "store/series.h"
#include "text_reader_test_util.h"

namespace mds {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::run_mdstream;

std::string bytes_of(const fs::path& p) { return textest::read_text(p); }

class SeriesCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    lj_ = new fs::path(textest::cached_lammps_run("in.lj_small"));
    ASSERT_FALSE(lj_->empty()) << "lmp failed on in.lj_small";
  }
  static void TearDownTestSuite() { delete lj_; }
  void SetUp() override { dir_ = std::make_unique<textest::TempDir>("series_cli"); }
  static fs::path dump() { return *lj_ / "dump.xyz.lammpstrj"; }
  fs::path tmp(const std::string& name) const { return dir_->path() / name; }
  // The regular files of the scratch folder.
  std::vector<std::string> listing() const {
    std::vector<std::string> v;
    for (const auto& e : fs::directory_iterator(dir_->path())) v.push_back(e.path().filename().string());
    std::sort(v.begin(), v.end());
    return v;
  }

  static fs::path* lj_;
  std::unique_ptr<textest::TempDir> dir_;
};
fs::path* SeriesCli::lj_ = nullptr;

TEST_F(SeriesCli, EveryFrameIsTheStoreOfThatFrame) {
  ASSERT_EQ(run_mdstream(fmt::format("convert {} -o {} -q", dump().string(), tmp("run.mds.series").string())), 0)
      << cli_stderr();
  auto series = store::read_series(tmp("run.mds.series"));
  ASSERT_TRUE(series.ok()) << series.error().message;
  const auto ref = textest::parse_reference_dump(textest::read_text(dump()));
  ASSERT_EQ(series->frames.size(), ref.size());
  for (size_t k = 0; k < ref.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(series->frames[k].name, fmt::format("run.{:04}.mds", k));
    EXPECT_EQ(series->frames[k].time, double(ref[k].timestep));
    const fs::path single = tmp(fmt::format("single{}.mds", k));
    ASSERT_EQ(run_mdstream(fmt::format("convert {} --frame {} -o {} -q", dump().string(), k, single.string())), 0)
        << cli_stderr();
    EXPECT_EQ(bytes_of(series->frames[k].path), bytes_of(single)) << "the series' store differs from --frame " << k;
  }
  // A slice of the frames, from the zstd dump (frames found by decompressing, marks re-read).
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames 1::2 -o {} -q --json-report {}",
                                     (*lj_ / "dump.lammpstrj.zst").string(), tmp("odd.series").string(),
                                     tmp("odd.json").string())),
            0)
      << cli_stderr();
  auto odd = store::read_series(tmp("odd.series"));
  ASSERT_TRUE(odd.ok()) << odd.error().message;
  ASSERT_EQ(odd->frames.size(), 2u);
  EXPECT_EQ(odd->frames[0].time, double(ref[1].timestep));
  EXPECT_EQ(odd->frames[1].time, double(ref[3].timestep));
  EXPECT_EQ(odd->frames[1].name, "odd.0001.mds");
  const auto report = nlohmann::json::parse(textest::read_text(tmp("odd.json")));
  ASSERT_EQ(report["frames"].size(), 2u);
  EXPECT_EQ(report["frames"][1]["input_frame"], 3);
  EXPECT_EQ(report["frames"][1]["particles"], ref[3].natoms);
}

// Files of one step each (LAMMPS' `dump ... dump.*.txt`), given out of order: one series in the
// order of their steps.
TEST_F(SeriesCli, FilesOfOneStepEachAreOrderedByStep) {
  const auto lines = textest::split_lines(textest::read_text(dump()));
  const size_t n = std::stoul(lines[3]), per = 9 + n;
  ASSERT_EQ(lines.size(), 5 * per);
  std::vector<std::string> names;
  for (size_t k : {3u, 0u, 4u}) {  // steps 150, 0, 200
    const std::string name = fmt::format("dump.{}.txt", k * 50);
    textest::write_text(tmp(name), textest::join_lines({lines.begin() + long(k * per), lines.begin() + long((k + 1) * per)}));
    names.push_back(tmp(name).string());
  }
  ASSERT_EQ(run_mdstream(fmt::format("convert {} {} {} -o {} -q", names[0], names[1], names[2],
                                     tmp("steps.mds.series").string())),
            0)
      << cli_stderr();
  auto s = store::read_series(tmp("steps.mds.series"));
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(s->frames.size(), 3u);
  EXPECT_EQ(s->frames[0].time, 0.0);
  EXPECT_EQ(s->frames[1].time, 150.0);
  EXPECT_EQ(s->frames[2].time, 200.0);
  ASSERT_EQ(run_mdstream(fmt::format("convert {} -o {} -q", names[0], tmp("150.mds").string())), 0) << cli_stderr();
  EXPECT_EQ(bytes_of(s->frames[1].path), bytes_of(tmp("150.mds")));
  // --frames picks frames of one input; with several it is an error.
  EXPECT_EQ(run_mdstream(fmt::format("convert {} {} --frames all -o {} -q", names[0], names[1],
                                     tmp("x.series").string())),
            2);
  EXPECT_THAT(cli_stderr(), HasSubstr("with 2 inputs each input is one frame"));
}

// Errors: a clear message, a non-zero exit, and no store or index left.
TEST_F(SeriesCli, ErrorsLeaveNothingBehind) {
  const auto before = listing();
  EXPECT_EQ(run_mdstream(fmt::format("convert {} --frames 7 -o {}", dump().string(), tmp("a.mds.series").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr(dump().string() + ": --frames '7': out of range: there are 5 frames"));
  EXPECT_EQ(run_mdstream(fmt::format("convert {} --frames 1 -o {}", dump().string(), tmp("a.mds").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("name its index RUN.mds.series"));
  EXPECT_EQ(run_mdstream(fmt::format("convert {} --frame 2 -o {}", dump().string(), tmp("a.series").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("pick the input's frames with --frames"));
  EXPECT_EQ(run_mdstream(fmt::format("convert {} --frames 1:x -o {}", dump().string(), tmp("a.series").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--frames '1:x': the stop is not an index"));
  // The fourth frame is broken (a NaN): the three stores before it are removed again.
  auto lines = textest::split_lines(textest::read_text(dump()));
  const size_t n = std::stoul(lines[3]), per = 9 + n;
  lines[3 * per + 9 + 17] = "18 1 nan 1 1";
  textest::write_text(tmp("broken.lammpstrj"), textest::join_lines(lines));
  const auto with_input = listing();
  EXPECT_NE(run_mdstream(fmt::format("convert {} -o {}", tmp("broken.lammpstrj").string(), tmp("b.mds.series").string())), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("series frame 3 of 5"));
  EXPECT_THAT(cli_stderr(), HasSubstr(fmt::format("broken.lammpstrj:{}", 3 * per + 9 + 17 + 1)));
  EXPECT_EQ(listing(), with_input);
  EXPECT_EQ(before.size() + 1, with_input.size());
  // Over an earlier series of the same name, the failed run keeps its stores and index as they were.
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames :2 -o {} -q", dump().string(), tmp("b.mds.series").string())), 0)
      << cli_stderr();
  const std::string index = bytes_of(tmp("b.mds.series")), store0 = bytes_of(tmp("b.0000.mds"));
  const auto kept = listing();
  EXPECT_NE(run_mdstream(fmt::format("convert {} -o {}", tmp("broken.lammpstrj").string(), tmp("b.mds.series").string())), 0);
  EXPECT_EQ(listing(), kept);
  EXPECT_EQ(bytes_of(tmp("b.mds.series")), index);
  EXPECT_EQ(bytes_of(tmp("b.0000.mds")), store0);
  // A series store that would overwrite an input is refused before any work.
  fs::copy_file(dump(), tmp("c.0000.mds"));
  EXPECT_EQ(run_mdstream(fmt::format("convert {} -o {}", tmp("c.0000.mds").string(), tmp("c.mds.series").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("would overwrite an input"));
}

TEST_F(SeriesCli, InfoListsTheFrames) {
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames :3 -o {} -q", dump().string(), tmp("i.mds.series").string())), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream(fmt::format("info {} --json --verify > {}", tmp("i.mds.series").string(), tmp("i.json").string())), 0)
      << cli_stderr();
  const auto j = nlohmann::json::parse(textest::read_text(tmp("i.json")));
  EXPECT_EQ(j["frame_count"], 3);
  EXPECT_EQ(j["particles_total"], 3 * 4000);
  EXPECT_EQ(j["frames"][2]["time"], 100.0);
  EXPECT_EQ(j["frames"][2]["name"], "i.0002.mds");
  EXPECT_TRUE(j["verified"].get<bool>());
  // Commands that take one store say so, and name one.
  EXPECT_EQ(run_mdstream(fmt::format("stress {} --gpu-budget 4MiB --path orbit --frames 2 --csv {}", tmp("i.mds.series").string(),
                                     tmp("x.csv").string())),
            2);
  EXPECT_THAT(cli_stderr(), HasSubstr("a store series index, not a store"));
  EXPECT_THAT(cli_stderr(), HasSubstr(tmp("i.0000.mds").string()));
  EXPECT_FALSE(fs::exists(tmp("x.csv")));
  // A store of the series gone: the error names the series, the frame and the store.
  fs::remove(tmp("i.0001.mds"));
  EXPECT_NE(run_mdstream(fmt::format("info {}", tmp("i.mds.series").string())), 0);
  EXPECT_THAT(cli_stderr(), HasSubstr("frame 1 (i.0001.mds)"));
}

// `render` of a series frame draws what `render` of its store draws with the same camera and
// colour range, bit for bit; an animation writes one image per picked frame, named by the
// series index, all with one camera and the colour range over every picked frame.
TEST_F(SeriesCli, RenderAFrameAndAnAnimation) {
  ASSERT_EQ(run_mdstream(fmt::format("convert {} -o {} -q", dump().string(), tmp("r.mds.series").string())), 0)
      << cli_stderr();
  const std::string look = "--width 96 --height 72 --spp 2 --color-by z";
  ASSERT_EQ(run_mdstream(fmt::format("render {} --series-frames 1:4 -o {} {} --stats {} --pick 48,36 > {}",
                                     tmp("r.mds.series").string(), tmp("f%02d.png").string(), look,
                                     tmp("anim.json").string(), tmp("picks.txt").string())),
            0)
      << cli_stderr();
  EXPECT_FALSE(fs::exists(tmp("f00.png")));
  for (int k = 1; k < 4; ++k) EXPECT_TRUE(fs::exists(tmp(fmt::format("f{:02}.png", k)))) << k;
  EXPECT_FALSE(fs::exists(tmp("f04.png")));
  const auto j = nlohmann::json::parse(textest::read_text(tmp("anim.json")));
  ASSERT_EQ(j["frames"].size(), 3u);
  auto info = nlohmann::json::array();
  double zlo = 1e300, zhi = -1e300;
  for (int k = 1; k < 4; ++k) {
    ASSERT_EQ(run_mdstream(fmt::format("info {} --json > {}", tmp(fmt::format("r.{:04}.mds", k)).string(),
                                       tmp("s.json").string())),
              0);
    const auto s = nlohmann::json::parse(textest::read_text(tmp("s.json")));
    zlo = std::min(zlo, s["bounds_min"][2].get<double>());
    zhi = std::max(zhi, s["bounds_max"][2].get<double>());
  }
  for (const auto& f : j["frames"]) {
    EXPECT_EQ(f["camera"]["eye"], j["frames"][0]["camera"]["eye"]);
    EXPECT_EQ(f["color_by"]["range"][0].get<double>(), zlo);  // over frames 1..3, not each frame's own
    EXPECT_EQ(f["color_by"]["range"][1].get<double>(), zhi);
  }
  EXPECT_EQ(j["frames"][2]["series_frame"], 3);
  EXPECT_EQ(j["frames"][2]["time"], 150.0);
  // --pick: a line per frame naming its series frame, as in that frame's stats.
  {
    std::istringstream lines(textest::read_text(tmp("picks.txt")));
    int k = 1;
    for (std::string line; std::getline(lines, line); ++k) {
      const auto p = nlohmann::json::parse(line);
      EXPECT_EQ(p["series_frame"], k) << line;
      ASSERT_LT(size_t(k - 1), j["frames"].size());
      EXPECT_EQ(p, j["frames"][size_t(k - 1)]["picks"][0]);
    }
    EXPECT_EQ(k, 4) << "one line per frame";
  }

  // Frame 2 alone with the animation's camera and range equals the store's own render.
  const auto& cam = j["frames"][1]["camera"];
  const std::string camera = fmt::format("--camera {},{},{},{},{},{},{},{},{}", cam["eye"][0].get<double>(),
                                         cam["eye"][1].get<double>(), cam["eye"][2].get<double>(),
                                         cam["target"][0].get<double>(), cam["target"][1].get<double>(),
                                         cam["target"][2].get<double>(), cam["up"][0].get<double>(),
                                         cam["up"][1].get<double>(), cam["up"][2].get<double>());
  const std::string range = fmt::format("--color-range {}:{}", zlo, zhi);
  ASSERT_EQ(run_mdstream(fmt::format("render {} -o {} {} {} {}", tmp("r.0002.mds").string(), tmp("store2.png").string(),
                                     look, camera, range)),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream(fmt::format("render {} --series-frames 2 -o {} {} {} {}", tmp("r.mds.series").string(),
                                     tmp("series2.png").string(), look, camera, range)),
            0)
      << cli_stderr();
  EXPECT_EQ(bytes_of(tmp("store2.png")), bytes_of(tmp("series2.png")));
  EXPECT_EQ(bytes_of(tmp("store2.png")), bytes_of(tmp("f02.png"))) << "the animation's frame 2 differs";

  // Usage errors.
  EXPECT_EQ(run_mdstream(fmt::format("render {} -o {} {}", tmp("r.mds.series").string(), tmp("one.png").string(), look)), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("no %d in the name"));
  EXPECT_EQ(run_mdstream(fmt::format("render {} --series-frames 9 -o {} {}", tmp("r.mds.series").string(),
                                     tmp("one.png").string(), look)),
            2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--series-frames '9': out of range: there are 5 frames"));
  EXPECT_EQ(run_mdstream(fmt::format("render {} --path orbit --camera 1,2,3,0,0,0 -o {} {}",
                                     tmp("r.mds.series").string(), tmp("o%d.png").string(), look)),
            2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--path and --camera"));
}

// A streamed series: each frame's cache starts from what the frame before wanted
// (--series-first-wave prior, the default; docs/streaming.md "Series steps"), and the stats say
// how many nodes that carried; `cold` carries nothing and draws the same images.
TEST_F(SeriesCli, AStreamedSeriesCarriesEachFramesViewToTheNext) {
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames :3 --node-size 500 -o {} -q", dump().string(),
                                     tmp("s.mds.series").string())),
            0)
      << cli_stderr();
  const std::string common = fmt::format("render {} --width 64 --height 48 --spp 2 --gpu-budget 4MiB",
                                         tmp("s.mds.series").string());
  for (const std::string wave : {"prior", "cold"}) {
    ASSERT_EQ(run_mdstream(fmt::format("{} --series-first-wave {} -o {} --stats {}", common, wave,
                                       tmp(wave + "%d.exr").string(), tmp(wave + ".json").string())),
              0)
        << cli_stderr();
    const auto j = nlohmann::json::parse(textest::read_text(tmp(wave + ".json")));
    ASSERT_EQ(j["frames"].size(), 3u);
    EXPECT_EQ(j["frames"][0]["prior_wanted_nodes"], 0) << "the first frame has no frame before";
    EXPECT_EQ(j["frames"][0]["carried_nodes"], 0);
    for (int k = 1; k < 3; ++k) {
      const auto& f = j["frames"][size_t(k)];
      EXPECT_GT(f["frames_to_complete"].get<int>(), 0) << k;
      if (wave == "prior") {
        EXPECT_EQ(f["prior_wanted_nodes"], j["frames"][size_t(k - 1)]["wanted_nodes"]) << k;
        EXPECT_GT(f["carried_nodes"].get<int>(), 0) << k;
      } else {
        EXPECT_EQ(f["prior_wanted_nodes"], 0) << k;
        EXPECT_EQ(f["carried_nodes"], 0) << k;
      }
    }
  }
  // The same data drawn: the images agree within the renderer's tolerance. Not byte for byte: the
  // culling classes depend on the order the nodes arrived in (the reader threads' timing), and a
  // node classified occluded may hide a sphere's last pixel (on one loaded core, 1 of 3072 pixels
  // differed in 9 of 75 cold runs).
  for (int k = 0; k < 3; ++k) {
    const auto d = mds::testing::compare_exr(tmp(fmt::format("prior{}.exr", k)), tmp(fmt::format("cold{}.exr", k)), 64, 48);
    EXPECT_GT(d.covered, size_t(64 * 48) / 10) << k;
    EXPECT_LE(d.differing, size_t(64 * 48) / 200) << k << ": " << d.differing << " of " << d.covered << " covered pixels";
  }
  EXPECT_EQ(run_mdstream(fmt::format("{} --series-first-wave warm -o {}", common, tmp("w%d.png").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--series-first-wave"));
  EXPECT_FALSE(fs::exists(tmp("w0.png")));
}

// --node-log (docs/streaming.md, "Node log"): one CSV row per node of each frame's store. Streamed,
// its columns add up to the frame's cache stats (bytes read, loaded, resident, wanted, carried,
// classes), a node was loaded only if read, read only if requested, and a step's carried nodes went out in its first wave (the
// pool holds the store). In memory, unculled, with --visible-reference: the visible column holds
// the frame's visible_nodes, and the cache's columns are empty. Several frames need a %d; a
// name without one fails before any image is written, and so does a log that cannot be written.
TEST_F(SeriesCli, NodeLogSaysWhatEachFramesCacheDid) {
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames :3 --node-size 300 -o {} -q", dump().string(),
                                     tmp("n.mds.series").string())),
            0)
      << cli_stderr();
  const std::string common = fmt::format("render {} --width 64 --height 48 --spp 2", tmp("n.mds.series").string());
  ASSERT_EQ(run_mdstream(fmt::format("{} --gpu-budget 4MiB -o {} --node-log {} --stats {}", common,
                                     tmp("s%d.png").string(), tmp("s%d.csv").string(), tmp("s.json").string())),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream(fmt::format("{} --no-cull --visible-reference -o {} --node-log {} --stats {}", common,
                                     tmp("m%d.png").string(), tmp("m%d.csv").string(), tmp("m.json").string())),
            0)
      << cli_stderr();
  const auto js = nlohmann::json::parse(textest::read_text(tmp("s.json")));
  const auto jm = nlohmann::json::parse(textest::read_text(tmp("m.json")));
  ASSERT_EQ(js["frames"].size(), 3u);
  ASSERT_EQ(jm["frames"].size(), 3u);
  const auto rows = [&](const std::string& name) {
    std::istringstream in(textest::read_text(tmp(name)));
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "node,particles,payload_bytes,class,visible,carried,requests,reads,first_request_frame,loaded,"
                    "resident,in_frustum,wanted");
    std::vector<std::vector<std::string>> out;
    while (std::getline(in, line)) {
      std::vector<std::string> cells;
      std::istringstream ls(line);
      for (std::string c; std::getline(ls, c, ',');) cells.push_back(c);
      if (!line.empty() && line.back() == ',') cells.emplace_back();
      EXPECT_EQ(cells.size(), 13u) << line;
      out.push_back(cells);
    }
    return out;
  };
  // The columns of a streamed row.
  enum { kCarried = 5, kRequests, kReads, kFirst, kLoaded, kResident, kInFrustum, kWanted, kColumns };
  for (size_t k = 0; k < 3; ++k) {
    SCOPED_TRACE(k);
    const auto& f = js["frames"][k];
    const auto s = rows(fmt::format("s{}.csv", k));
    ASSERT_EQ(s.size(), f["nodes"].get<size_t>());
    uint64_t particles = 0, loaded = 0, resident = 0, wanted = 0, carried = 0, read_bytes = 0;
    std::map<std::string, uint64_t> classes;
    int64_t first_wave = INT64_MAX;
    for (size_t i = 0; i < s.size(); ++i) {
      const auto& r = s[i];
      EXPECT_EQ(r[0], std::to_string(i));
      particles += std::stoull(r[1]);
      ++classes[r[3]];
      EXPECT_EQ(r[4], "") << "no --visible-reference";
      const uint64_t requests = std::stoull(r[kRequests]), reads = std::stoull(r[kReads]);
      const int64_t first = std::stoll(r[kFirst]);
      EXPECT_EQ(requests == 0, first == -1) << r[0];
      EXPECT_LE(reads, requests) << r[0];
      read_bytes += reads * std::stoull(r[2]);
      if (requests > 0) first_wave = std::min(first_wave, first);
      loaded += r[kLoaded] == "1";
      resident += r[kResident] == "1";
      wanted += r[kWanted] == "1";
      carried += r[kCarried] == "1";
      if (r[kLoaded] == "1") {
        EXPECT_GT(reads, 0u) << "node " << r[0] << " loaded without a read";
      }
      if (r[kResident] == "1") {
        EXPECT_EQ(r[kLoaded], "1") << r[0];
      }
    }
    EXPECT_EQ(particles, f["particles"].get<uint64_t>());
    EXPECT_EQ(read_bytes, f["bytes_read"].get<uint64_t>());
    EXPECT_EQ(loaded, f["nodes"].get<uint64_t>() - f["nodes_never_loaded"].get<uint64_t>());
    EXPECT_EQ(resident, f["nodes_resident"].get<uint64_t>());
    EXPECT_EQ(wanted, f["wanted_nodes"].get<uint64_t>());
    EXPECT_EQ(carried, f["carried_nodes"].get<uint64_t>());
    for (const char* c : {"P", "L", "M", "O"}) EXPECT_EQ(classes[c], f["node_class_counts"][c].get<uint64_t>()) << c;
    if (k > 0) {
      ASSERT_GT(carried, 0u);
      for (const auto& r : s) {
        if (r[kCarried] == "1" && r[kRequests] != "0") {
          EXPECT_EQ(std::stoll(r[kFirst]), first_wave) << "carried node " << r[0];
        }
      }
    }
    const auto m = rows(fmt::format("m{}.csv", k));
    ASSERT_EQ(m.size(), s.size());
    uint64_t visible = 0;
    for (const auto& r : m) {
      EXPECT_EQ(r[3], "") << "--no-cull: no classes";
      EXPECT_TRUE(r[4] == "0" || r[4] == "1") << r[4];
      visible += r[4] == "1";
      for (size_t c = kCarried; c < kColumns; ++c) EXPECT_EQ(r[c], "") << "in memory: no cache column " << c;
    }
    EXPECT_EQ(visible, jm["frames"][k]["visible_nodes"].get<uint64_t>());
    EXPECT_GT(visible, 0u);
  }
  EXPECT_EQ(run_mdstream(fmt::format("{} --no-cull -o {} --node-log {}", common, tmp("e%d.png").string(),
                                     tmp("e.csv").string())),
            2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--node-log"));
  EXPECT_FALSE(fs::exists(tmp("e0.png")));
  EXPECT_FALSE(fs::exists(tmp("e.csv")));
  // One frame: a %d in the log's name alone still takes the frame's index.
  ASSERT_EQ(run_mdstream(fmt::format("{} --no-cull --series-frames 1 -o {} --node-log {}", common,
                                     tmp("one.png").string(), tmp("one%d.csv").string())),
            0)
      << cli_stderr();
  EXPECT_TRUE(fs::exists(tmp("one1.csv")));
  // A log that cannot be written leaves no image behind.
  EXPECT_NE(run_mdstream(fmt::format("{} --no-cull --series-frames 1 -o {} --node-log {}", common,
                                     tmp("two.png").string(), tmp("no/such/dir.csv").string())),
            0);
  EXPECT_FALSE(fs::exists(tmp("two.png")));
}

// --path with a series: the camera orbits while the frames go, one path frame per picked frame,
// around the picked frames' bounds (the same distance from their centre in every frame).
TEST_F(SeriesCli, OrbitWhileTheFramesGo) {
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames :4 -o {} -q", dump().string(), tmp("p.mds.series").string())), 0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream(fmt::format("render {} --path orbit -o {} --width 64 --height 48 --spp 1 --no-cull --stats {}",
                                     tmp("p.mds.series").string(), tmp("o%d.png").string(), tmp("o.json").string())),
            0)
      << cli_stderr();
  const auto j = nlohmann::json::parse(textest::read_text(tmp("o.json")));
  ASSERT_EQ(j["frames"].size(), 4u);
  const auto eye = [&](size_t i, int d) { return j["frames"][i]["camera"]["eye"][d].get<double>(); };
  const auto target = [&](size_t i, int d) { return j["frames"][i]["camera"]["target"][d].get<double>(); };
  const auto dist = [&](size_t i) {
    double s = 0;
    for (int d = 0; d < 3; ++d) s += (eye(i, d) - target(i, d)) * (eye(i, d) - target(i, d));
    return std::sqrt(s);
  };
  for (size_t i = 1; i < 4; ++i) {
    EXPECT_NE(eye(i, 0), eye(0, 0)) << "frame " << i << " has frame 0's camera";
    EXPECT_NEAR(dist(i), dist(0), 1e-9 * dist(0));
    for (int d = 0; d < 3; ++d) EXPECT_EQ(target(i, d), target(0, d));
    EXPECT_TRUE(fs::exists(tmp(fmt::format("o{}.png", i))));
  }
}

// `export SERIES`: one XYZ or LAMMPS dump file with a frame per picked store, each the store's own
// export with the series time (XYZ: a Time key; dump: the timestep, or ITEM: TIME for a time that
// is not a whole number), read back by convert as a series with those times; MMPLD takes one
// frame; a filter that keeps nothing in every frame is refused, leaving no file.
TEST_F(SeriesCli, ExportWritesAFramePerStore) {
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames :3 -o {} -q", dump().string(), tmp("e.mds.series").string())), 0)
      << cli_stderr();
  const auto series = store::read_series(tmp("e.mds.series"));
  ASSERT_TRUE(series.ok());
  std::string want_xyz, want_dump;
  for (size_t k = 0; k < 3; ++k) {
    const std::string store = series->frames[k].path.string();
    ASSERT_EQ(run_mdstream(fmt::format("export {} -o {}", store, tmp(fmt::format("f{}.xyz", k)).string())), 0) << cli_stderr();
    std::string x = bytes_of(tmp(fmt::format("f{}.xyz", k)));
    const size_t key = x.find(" mdstream_format=");
    ASSERT_NE(key, std::string::npos);
    want_xyz += x.insert(key, fmt::format(" Time={}", series->frames[k].time));
    if (k == 0) continue;
    ASSERT_EQ(run_mdstream(fmt::format("export {} -o {}", store, tmp(fmt::format("f{}.dump", k)).string())), 0) << cli_stderr();
    std::string d = bytes_of(tmp(fmt::format("f{}.dump", k)));
    ASSERT_EQ(d.rfind("ITEM: TIMESTEP\n0\n", 0), 0u);
    want_dump += fmt::format("ITEM: TIMESTEP\n{}\n", series->frames[k].time) + d.substr(17);
  }
  ASSERT_EQ(run_mdstream(fmt::format("export {} -o {}", tmp("e.mds.series").string(), tmp("all.xyz").string())), 0)
      << cli_stderr();
  EXPECT_EQ(bytes_of(tmp("all.xyz")), want_xyz);
  ASSERT_EQ(run_mdstream(fmt::format("export {} --series-frames 1: -o {}", tmp("e.mds.series").string(),
                                     tmp("late.lammpstrj").string())),
            0)
      << cli_stderr();
  EXPECT_EQ(bytes_of(tmp("late.lammpstrj")), want_dump);
  // convert reads the dump's frames back with their steps as times.
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames : -o {} -q", tmp("late.lammpstrj").string(),
                                     tmp("back.mds.series").string())),
            0)
      << cli_stderr();
  const auto back = store::read_series(tmp("back.mds.series"));
  ASSERT_TRUE(back.ok());
  ASSERT_EQ(back->frames.size(), 2u);
  EXPECT_EQ(back->frames[0].time, series->frames[1].time);
  EXPECT_EQ(back->frames[1].time, series->frames[2].time);

  // A time that is not a whole step: every frame has ITEM: TIME and its series index as the
  // timestep (one rule for the file: steps never repeat or mix with indices).
  textest::write_text(tmp("half.series"), fmt::format("{{\"file-series-version\": \"1.0\", \"files\": [{{\"name\": "
                                                      "\"e.0000.mds\", \"time\": 0.5}}, {{\"name\": \"e.0002.mds\", "
                                                      "\"time\": 7}}]}}"));
  ASSERT_EQ(run_mdstream(fmt::format("export {} -o {}", tmp("half.series").string(), tmp("half.dump").string())), 0)
      << cli_stderr();
  const std::string half = bytes_of(tmp("half.dump"));
  EXPECT_EQ(half.rfind("ITEM: TIME\n0.5\nITEM: TIMESTEP\n0\n", 0), 0u) << half.substr(0, 60);
  EXPECT_THAT(half, HasSubstr("\nITEM: TIME\n7\nITEM: TIMESTEP\n1\n"));

  // MMPLD holds one frame: a series of several is refused, one picked frame is its store's export.
  EXPECT_EQ(run_mdstream(fmt::format("export {} -o {}", tmp("e.mds.series").string(), tmp("bad.mmpld").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("an MMPLD export holds one frame"));
  ASSERT_EQ(run_mdstream(fmt::format("export {} --series-frames 2 -o {}", tmp("e.mds.series").string(),
                                     tmp("two.mmpld").string())),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream(fmt::format("export {} -o {}", series->frames[2].path.string(), tmp("two_store.mmpld").string())), 0);
  EXPECT_EQ(bytes_of(tmp("two.mmpld")), bytes_of(tmp("two_store.mmpld")));
  // A LAMMPS data file too: several frames refused, one picked frame is its store's export.
  EXPECT_EQ(run_mdstream(fmt::format("export {} -o {}", tmp("e.mds.series").string(), tmp("bad.data").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("a LAMMPS data file holds one frame"));
  ASSERT_EQ(run_mdstream(fmt::format("export {} --series-frames 1 -o {}", tmp("e.mds.series").string(),
                                     tmp("one.data").string())),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream(fmt::format("export {} -o {}", series->frames[1].path.string(), tmp("one_store.data").string())), 0);
  EXPECT_EQ(bytes_of(tmp("one.data")), bytes_of(tmp("one_store.data")));
  // A slice that keeps nothing in any frame; --threshold without a property; --series-frames of one store.
  EXPECT_EQ(run_mdstream(fmt::format("export {} --slice 0,0,1,-100 -o {}", tmp("e.mds.series").string(),
                                     tmp("bad.xyz").string())),
            2);
  EXPECT_THAT(cli_stderr(), HasSubstr("in every picked frame"));
  EXPECT_EQ(run_mdstream(fmt::format("export {} --threshold 0:1 -o {}", tmp("e.mds.series").string(), tmp("bad.xyz").string())),
            2);
  EXPECT_THAT(cli_stderr(), HasSubstr("frame 0 (e.0000.mds): --threshold 0:1"));
  EXPECT_EQ(run_mdstream(fmt::format("export {} --series-frames 1 -o {}", series->frames[0].path.string(),
                                     tmp("bad.xyz").string())),
            2);
  EXPECT_THAT(cli_stderr(), HasSubstr("is one store, not a series"));
  for (const auto& name : listing()) EXPECT_EQ(name.rfind("bad", 0), std::string::npos) << name << " was written";
}

// --label (overlay/text_label.h): each series frame's image carries its own time, drawn after the
// colour legend in the corner they share, and --axes the tripod after both: the labelled image is
// the unlabelled one with overlay_text_label and overlay_tripod (the frame's camera) applied, to the bit, and the stats say the text and its box. A camera path
// over one store numbers its frames; {time} on one store and an unknown placeholder are refused
// before any image is written.
TEST_F(SeriesCli, LabelsEachFrameWithItsTime) {
  ASSERT_EQ(run_mdstream(fmt::format("convert {} --frames :3 -o {} -q", dump().string(), tmp("l.mds.series").string())), 0)
      << cli_stderr();
  const auto series = store::read_series(tmp("l.mds.series"));
  ASSERT_TRUE(series.ok());
  const std::string common = fmt::format("render {} --width 120 --height 180 --spp 1 --no-cull --color-legend top-left",
                                         tmp("l.mds.series").string());
  ASSERT_EQ(run_mdstream(fmt::format("{} -o {}", common, tmp("plain%d.exr").string())), 0) << cli_stderr();
  ASSERT_EQ(run_mdstream(fmt::format("{} --label 'step {{time}} ({{frame}})' --axes top-left -o {} --stats {}", common,
                                     tmp("lab%d.exr").string(), tmp("lab.json").string())),
            0)
      << cli_stderr();
  const auto j = nlohmann::json::parse(textest::read_text(tmp("lab.json")));
  ASSERT_EQ(j["frames"].size(), 3u);
  std::vector<float> first_label;
  for (size_t k = 0; k < 3; ++k) {
    SCOPED_TRACE(k);
    const std::string text = fmt::format("step {} ({})", series->frames[k].time, k);
    const auto& f = j["frames"][k];
    ASSERT_EQ(f["label"]["text"], text);
    EXPECT_EQ(f["label"]["corner"], "top-left");
    const overlay::PixelBox legend{f["color_legend"]["box"][0], f["color_legend"]["box"][1], f["color_legend"]["box"][2],
                                   f["color_legend"]["box"][3]};
    render::FrameImage plain{120, 180, mds::testing::load_exr(tmp(fmt::format("plain{}.exr", k)))};
    const std::vector<float> labelled = mds::testing::load_exr(tmp(fmt::format("lab{}.exr", k)));
    ASSERT_EQ(plain.rgba.size(), labelled.size());
    EXPECT_NE(plain.rgba, labelled);
    const overlay::PixelBox box = overlay::overlay_text_label(plain, text, overlay::LegendCorner::top_left, legend);
    // The tripod of the frame's camera after the label.
    const auto& cam = f["camera"];
    render::Camera c;
    for (int d = 0; d < 3; ++d) {
      c.eye[d] = cam["eye"][d];
      c.target[d] = cam["target"][d];
      c.up[d] = cam["up"][d];
    }
    const overlay::PixelBox axes = overlay::overlay_tripod(plain, c, overlay::LegendCorner::top_left, box);
    EXPECT_EQ(plain.rgba, labelled) << "not the unlabelled image with \"" << text << "\" and the tripod after the legend";
    EXPECT_EQ(f["label"]["box"], nlohmann::json({box.x0, box.y0, box.x1, box.y1}));
    EXPECT_EQ(f["axes"]["box"], nlohmann::json({axes.x0, axes.y0, axes.x1, axes.y1}));
    EXPECT_GE(box.y0, legend.y1);
    EXPECT_FALSE(axes.empty());
    EXPECT_GE(axes.y0, box.y1);
  }
  EXPECT_NE(series->frames[0].time, series->frames[1].time) << "the frames' labels should differ";

  // A camera path over one store: {frame} is the path's frame; the stats list each frame's text.
  const std::string store0 = series->frames[0].path.string();
  ASSERT_EQ(run_mdstream(fmt::format("render {} --path orbit --frames 3 --width 48 --height 32 --spp 1 --no-cull "
                                     "--label '{{store}} {{frame:02d}}' --label-corner bottom-right -o {} --stats {}",
                                     store0, tmp("o%d.png").string(), tmp("o.json").string())),
            0)
      << cli_stderr();
  const auto o = nlohmann::json::parse(textest::read_text(tmp("o.json")));
  ASSERT_EQ(o["frame_stats"].size(), 3u);
  for (size_t i = 0; i < 3; ++i)
    EXPECT_EQ(o["frame_stats"][i]["label"], fmt::format("{} {:02d}", series->frames[0].path.filename().string(), i));

  // Refused before any image: {time} of one store, an unknown placeholder in a series, a bad corner.
  EXPECT_EQ(run_mdstream(fmt::format("render {} --spp 1 --label 'step {{time}}' -o {}", store0, tmp("bad.png").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("{time} is the time of a series frame"));
  EXPECT_EQ(run_mdstream(fmt::format("{} --label 'at {{timestep}}' -o {}", common, tmp("bad%d.png").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--label 'at {timestep}': argument not found"));
  EXPECT_EQ(run_mdstream(fmt::format("{} --label x --label-corner middle -o {}", common, tmp("bad%d.png").string())), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--label-corner 'middle'"));
  for (const auto& name : listing()) EXPECT_EQ(name.rfind("bad", 0), std::string::npos) << name << " was written";
}

}  // namespace
}  // namespace mds
