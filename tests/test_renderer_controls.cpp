// The renderer's controls for the viewer, on a real store streamed through a real pool on
// lavapipe:
//  - resident_nodes (the resident-bounds view) agrees with the cache's own accounting (count and
//    device bytes of the resident nodes) after a view converged and after a camera change, and is
//    empty in memory;
//  - set_c_occ / set_spp change the settings in place: the cache survives, the view restarts and
//    converges to the image of a renderer created with the new C_occ; bad values are errors;
//    set_coverage restarts the view with the new sample-area model.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "render/camera.h"
#include "render_test_helpers.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "store/store_reader.h"
#include "vk/context.h"

namespace fs = std::filesystem;
using namespace mds;
using namespace mds::render;

namespace {

using mds::testing::differing_pixels;
int run(const std::string& args) { return mds::testing::run_mdstream_quietly(args); }

// Resident count and device bytes by resident_nodes(), against the cache statistics.
void expect_consistent(const Renderer& r) {
  const std::vector<uint8_t> res = r.resident_nodes();
  const std::vector<uint64_t> bytes = r.node_device_bytes();
  ASSERT_EQ(res.size(), bytes.size());
  uint64_t n = 0, b = 0;
  for (size_t i = 0; i < res.size(); ++i) {
    ASSERT_LE(res[i], 1u);
    if (res[i]) {
      ++n;
      b += bytes[i];
    }
  }
  const CacheStats c = r.stats().cache;
  EXPECT_EQ(n, c.nodes_resident);
  EXPECT_EQ(b, c.resident_bytes);
  EXPECT_GT(n, 0u);
  EXPECT_LT(n, res.size()) << "the budget holds part of the store";
}

// A porous store of `particles` with nodes of <= 1000, written into a fresh folder `dir`.
void write_porous_store(const fs::path& dir, uint32_t particles, std::string& store) {
  fs::create_directories(dir);
  const std::string dump = (dir / "p.dump").string();
  store = (dir / "p.mds").string();
  ASSERT_EQ(run("synth --scene porous --particles " + std::to_string(particles) + " -q -o " + dump), 0);
  ASSERT_EQ(run("convert " + dump + " --node-size 1000 -q -o " + store), 0);
}

// Steps until the view converged (and at least `samples` were accumulated); the last report.
FrameReport settle(Renderer& r, uint32_t samples = 0) {
  FrameReport rep;
  for (int f = 0; f < 400; ++f) {
    auto s = r.step();
    EXPECT_TRUE(s.ok()) << s.error().message;
    if (!s.ok()) break;
    rep = *s;
    if (rep.converged && rep.samples >= samples) break;
  }
  EXPECT_TRUE(rep.converged);
  return rep;
}


}  // namespace

TEST(RendererControls, ResidencyAndLiveSettingsOnAStreamedStore) {
  const fs::path dir = fs::temp_directory_path() / ("mds_residency_" + std::to_string(::getpid()));
  std::string store;
  ASSERT_NO_FATAL_FAILURE(write_porous_store(dir, 100000, store));
  auto reader = store::StoreReader::open(store);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto ctx = vk::Context::create(vk::ContextOptions::from_env());
  ASSERT_TRUE(ctx.ok()) << ctx.error().message;
  RenderSettings rs;
  rs.width = 96;
  rs.height = 72;
  rs.spp = 2;
  rs.cull = true;
  StreamSettings ss;
  ss.gpu_budget = fs::file_size(store) / 4;
  auto r = Renderer::create_streaming(**ctx, **reader, rs, ss);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (int view : {2, 0}) {
    SCOPED_TRACE(::testing::Message() << "view " << view);
    auto cam = default_view(view, (*r)->bounds(), 40.0, 96.0 / 72.0);
    ASSERT_TRUE(cam.ok());
    ASSERT_TRUE((*r)->set_view(*cam).ok());
    bool converged = false;
    for (int f = 0; f < 400 && !converged; ++f) {
      auto rep = (*r)->step();
      ASSERT_TRUE(rep.ok()) << rep.error().message;
      converged = rep->converged;
    }
    EXPECT_TRUE(converged);
    expect_consistent(**r);
  }
  // set_c_occ: nothing is evicted by the call; the view restarts (culling runs again) and
  // converges to what a renderer created with the new C_occ shows.
  const std::vector<uint8_t> before = (*r)->resident_nodes();
  EXPECT_FALSE((*r)->set_c_occ(1.0).ok());
  EXPECT_FALSE((*r)->set_c_occ(0.0).ok());
  ASSERT_TRUE((*r)->set_c_occ(0.9).ok());
  EXPECT_EQ((*r)->resident_nodes(), before);
  EXPECT_DOUBLE_EQ((*r)->cull_loop()->settings().c_occ, 0.9);
  auto first = (*r)->step();
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_TRUE(first->culling_active);
  EXPECT_LE(first->samples, 1u) << "the accumulation restarted";
  const uint64_t loaded_before = (*r)->stats().cache.nodes_loaded;
  settle(**r, rs.spp);
  // set_spp: accumulation goes on to the new count without a restart.
  EXPECT_FALSE((*r)->set_spp(0).ok());
  ASSERT_TRUE((*r)->set_spp(6).ok());
  const FrameReport more = settle(**r, 6);
  EXPECT_EQ(more.samples, 6u);
  auto img = (*r)->read_image();
  ASSERT_TRUE(img.ok());
  RenderSettings rs9 = rs;
  rs9.cull_settings.c_occ = 0.9;
  rs9.spp = 6;
  auto fresh = Renderer::create_streaming(**ctx, **reader, rs9, ss);
  ASSERT_TRUE(fresh.ok()) << fresh.error().message;
  auto cam0 = default_view(0, (*fresh)->bounds(), 40.0, 96.0 / 72.0);
  ASSERT_TRUE((*fresh)->set_view(*cam0).ok());
  settle(**fresh, 6);
  auto ref = (*fresh)->read_image();
  ASSERT_TRUE(ref.ok());
  EXPECT_LE(differing_pixels(*img, *ref), img->rgba.size() / 4 / 100) << "within the renderer's 1 % tolerance";
  EXPECT_GE((*r)->stats().cache.nodes_loaded, loaded_before);
  fresh->reset();
  // set_coverage: the same in place for the sample-area model; the view restarts with it.
  ASSERT_TRUE((*r)->set_coverage(culling::Coverage::exact).ok());
  EXPECT_EQ((*r)->resident_nodes().size(), before.size());
  auto restarted = (*r)->step();
  ASSERT_TRUE(restarted.ok()) << restarted.error().message;
  EXPECT_TRUE(restarted->culling_active);
  EXPECT_LE(restarted->samples, 1u) << "the accumulation restarted";
  EXPECT_EQ((*r)->cull_loop()->settings().coverage, culling::Coverage::exact);
  settle(**r, 6);
  ASSERT_TRUE((*r)->set_coverage(culling::Coverage::expected).ok());
  ASSERT_TRUE((*r)->step().ok());
  EXPECT_EQ((*r)->cull_loop()->settings().coverage, culling::Coverage::expected);

  // In memory: no residency.
  auto scene = load_scene(**reader);
  ASSERT_TRUE(scene.ok());
  auto mem = Renderer::create(**ctx, *scene, rs);
  ASSERT_TRUE(mem.ok()) << mem.error().message;
  EXPECT_TRUE((*mem)->resident_nodes().empty());
  r->reset();
  mem->reset();
  fs::remove_all(dir);
}

// While the camera moves every frame is a new view of one sampling pass, so the automatic
// sampling route compares by probes only (sample_route.h kSampleRouteMovingHysteresis): the running
// route (compute when none has won) samples, one pass of the other over a quarter of the budget
// is timed beside it, and no whole pass of the other route is paid in a moving frame. The
// comparison completes while moving (until 2026-11-26 a comparison begun in motion was never
// collected, so no route was ever compared while the camera moved).
TEST(RendererControls, AMovingCameraComparesTheSamplingRoutesByProbes) {
  const fs::path dir = fs::temp_directory_path() / ("mds_moving_route_" + std::to_string(::getpid()));
  std::string store;
  ASSERT_NO_FATAL_FAILURE(write_porous_store(dir, 60000, store));
  auto reader = store::StoreReader::open(store);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto ctx = vk::Context::create(vk::ContextOptions::from_env());
  ASSERT_TRUE(ctx.ok()) << ctx.error().message;
  if (!(*ctx)->int64_atomics()) GTEST_SKIP() << "no 64-bit buffer atomics: only the rasterized route exists";
  auto scene = load_scene(**reader);
  ASSERT_TRUE(scene.ok());
  RenderSettings rs;
  rs.width = 96;
  rs.height = 72;
  rs.spp = 4;
  rs.cull = true;
  auto r = Renderer::create(**ctx, *scene, rs);
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto cam = default_view(0, (*r)->bounds(), 40.0, 96.0 / 72.0);
  ASSERT_TRUE(cam.ok());
  const glm::dvec3 step_dir = 0.02 * (cam->target - cam->eye);
  for (int f = 0; f < 12; ++f) {
    Camera c = *cam;
    c.eye += double(f) * step_dir;
    c.target += double(f) * step_dir;
    (*r)->set_motion(true);
    ASSERT_TRUE((*r)->set_view(c).ok());
    auto rep = (*r)->step();
    ASSERT_TRUE(rep.ok()) << rep.error().message;
    ASSERT_TRUE((*r)->finish().ok());
  }
  const RenderStats st = (*r)->stats();
  EXPECT_GE(st.cull.sample_passes_compute, 11u);
  EXPECT_EQ(st.cull.sample_passes_raster, 0u) << "a whole rasterized pass in a moving frame";
  EXPECT_GT(st.cull.sample_ms_compute, 0.0) << "no comparison completed while moving";
  EXPECT_GT(st.cull.sample_ms_raster, 0.0) << "no probe of the rasterized route";
  r->reset();
  fs::remove_all(dir);
}
