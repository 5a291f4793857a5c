// The viewer's RenderHost (viewer/render_host.h) without a window, on a real series of stores
// (synth --frames 3, convert -o run.mds.series) and real Vulkan (lavapipe here):
//  - a frame preloaded beside the render thread (RenderHost::preload) is the one a step takes:
//    it is shown even when its store file is gone by then, while a step to a frame not
//    preloaded fails on the missing file, names it, and keeps the frame before;
//  - slices changed after the preload are applied: the step loads the frame again with them;
//  - MDSTREAM_SERIES_PRELOAD=0 preloads nothing;
//  - in memory, the culling scene made with the loaded frame (RenderSettings::cull_scene) gives
//    the image a renderer that makes its own gives, bit for bit; one of another scene is refused;
//  - streaming, a step hands the cache's view to the next frame's renderer (StreamSettings::prior:
//    its first wave, test_series_stream.cpp), unless --series-first-wave cold.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "render/camera.h"
#include "render/culling/density_volume.h"
#include "render_test_helpers.h"
#include "scoped_temp_dir.h"
#include "store/slice.h"
#include "viewer/render_host.h"

namespace fs = std::filesystem;
using namespace mds;

namespace {

class RenderHostSeries : public mds::testing::VulkanSuite {
 protected:
  static void SetUpTestSuite() {
    VulkanSuite::SetUpTestSuite();
    dir_ = new mds::test::ScopedTempDir("mds_render_host_");
    const fs::path dump = dir_->p / "gas.lammpstrj";
    ASSERT_EQ(mds::testing::run_mdstream_quietly("synth --scene gas -n 20000 --frames 3 -q -o " + dump.string()), 0);
    ASSERT_EQ(mds::testing::run_mdstream_quietly("convert " + dump.string() + " -q -o " + series()), 0);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
    VulkanSuite::TearDownTestSuite();
  }
  static std::string series() { return (dir_->p / "run.mds.series").string(); }
  static fs::path store(int k) { return dir_->p / ("run.000" + std::to_string(k) + ".mds"); }

  std::unique_ptr<viewer::RenderHost> open_host(const std::string& path, std::vector<store::Slice> slices = {},
                                                uint64_t gpu_budget = 0, bool carry_view = true) {
    viewer::ViewerOptions o;
    o.store = path;
    o.gpu_budget = gpu_budget;
    o.stream.carry_view = carry_view;
    o.render.width = 64;
    o.render.height = 48;
    o.render.spp = 1;
    o.slices = std::move(slices);
    auto h = viewer::RenderHost::open(*ctx_, o);
    EXPECT_TRUE(h.ok()) << (h.ok() ? "" : h.error().message);
    if (!h.ok()) return nullptr;
    EXPECT_TRUE((*h)->recreate(64, 48).ok());
    return std::move(*h);
  }
  static bool wait_ready(const viewer::RenderHost& h, size_t position) {
    for (int i = 0; i < 600; ++i) {
      if (h.preload_ready(position)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return false;
  }
  static inline mds::test::ScopedTempDir* dir_ = nullptr;
};

// A series whose first frame has per-particle colours and whose second has none: the colour
// keys offer them only when every frame has them (has_colors), --color-by auto draws the types
// in every frame, and --color-by color is refused at open (as `render` refuses it).
TEST_F(RenderHostSeries, ColoursOnlyWhenEveryFrameHasThem) {
  const fs::path xyz = dir_->p / "c.xyz";
  {
    std::ofstream f(xyz);
    f << "3\nProperties=species:S:1:pos:R:3:color:R:3\nA 0 0 0 1 0 0\nA 2 0 0 0 1 0\nA 0 2 1 0 0 1\n";
  }
  ASSERT_EQ(mds::testing::run_mdstream_quietly("convert " + xyz.string() + " --color -q -o " + (dir_->p / "m0.mds").string()), 0);
  ASSERT_EQ(mds::testing::run_mdstream_quietly("convert " + xyz.string() + " -q -o " + (dir_->p / "m1.mds").string()), 0);
  const std::string mixed = (dir_->p / "mixed.series").string();
  {
    std::ofstream f(mixed);
    f << R"({ "file-series-version": "1.0", "files": [ { "name": "m0.mds", "time": 0 }, { "name": "m1.mds", "time": 1 } ] })";
  }
  auto open_with = [&](const std::string& path, int axis) {
    viewer::ViewerOptions o;
    o.store = path;
    o.render.width = 64;
    o.render.height = 48;
    o.render.color_by.axis = axis;  // as the CLI gives --color-by
    return viewer::RenderHost::open(*ctx_, o);
  };
  auto host = open_with(mixed, render::kColorByAuto);
  ASSERT_TRUE(host.ok()) << host.error().message;
  EXPECT_FALSE((*host)->has_colors());  // frame 0 has them, frame 1 not
  EXPECT_FALSE((*host)->settings().color_by.by_color());
  ASSERT_TRUE((*host)->recreate(64, 48).ok());
  ASSERT_TRUE((*host)->set_series_position(1).ok());
  EXPECT_FALSE((*host)->settings().color_by.by_color());
  auto one = open_with((dir_->p / "m0.mds").string(), render::kColorByAuto);  // the coloured store alone
  ASSERT_TRUE(one.ok()) << one.error().message;
  EXPECT_TRUE((*one)->has_colors());
  EXPECT_TRUE((*one)->settings().color_by.by_color());

  auto refused = open_with(mixed, render::kColorByColor);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("not every picked frame"), std::string::npos) << refused.error().message;
}

TEST_F(RenderHostSeries, APreloadedFrameIsTakenEvenWithItsFileGone) {
  auto h = open_host(series());
  ASSERT_TRUE(h);
  const uint64_t shown0 = h->scene()->particle_count();
  h->preload(1);
  // The current frame renders meanwhile, as in the viewer (ThreadSanitizer: tools/sanitize.sh).
  auto cam = render::default_view(0, h->view_bounds(), 40.0, 64.0 / 48.0);
  ASSERT_TRUE(cam.ok());
  ASSERT_TRUE(h->renderer()->set_view(*cam).ok());
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(h->renderer()->step().ok());
  ASSERT_TRUE(wait_ready(*h, 1));
  const fs::path moved1 = store(1).string() + ".away", moved2 = store(2).string() + ".away";
  fs::rename(store(1), moved1);
  fs::rename(store(2), moved2);
  const Status st1 = h->set_series_position(1);
  const Status st2 = h->set_series_position(2);  // not preloaded: its file is read now
  fs::rename(moved1, store(1));
  fs::rename(moved2, store(2));
  ASSERT_TRUE(st1.ok()) << st1.error().message;
  ASSERT_FALSE(st2.ok());
  EXPECT_NE(st2.error().message.find("frame 2 (run.0002.mds)"), std::string::npos) << st2.error().message;
  EXPECT_EQ(h->series_frame(), 1) << "a failed step keeps the frame before";
  ASSERT_NE(h->renderer(), nullptr);
  EXPECT_EQ(h->reader().path(), store(1));
  EXPECT_EQ(h->scene()->particle_count(), 20000u);
  EXPECT_EQ(shown0, 20000u);
}

TEST_F(RenderHostSeries, SlicesChangedAfterThePreloadAreApplied) {
  auto h = open_host(series());
  ASSERT_TRUE(h);
  h->preload(1);
  ASSERT_TRUE(wait_ready(*h, 1));
  auto slab = store::parse_slice("1,0,0,0");  // leaves out x > D: D set to the box's middle
  ASSERT_TRUE(slab.ok());
  const store::FileHeader& hd = h->reader().header();
  slab->distance = 0.5 * (hd.bounds_min[0] + hd.bounds_max[0]);
  ASSERT_TRUE(h->set_slices({*slab}).ok());
  ASSERT_TRUE(h->set_series_position(1).ok());
  auto direct = open_host(store(1).string(), {*slab});  // frame 1's store on its own, with the slice
  ASSERT_TRUE(direct);
  const uint64_t kept = h->scene()->particle_count();
  EXPECT_EQ(kept, direct->scene()->particle_count());
  EXPECT_GT(kept, 0u);
  EXPECT_LT(kept, 20000u);
}

TEST_F(RenderHostSeries, PreloadOffLoadsNothingAhead) {
  setenv("MDSTREAM_SERIES_PRELOAD", "0", 1);
  auto h = open_host(series());
  unsetenv("MDSTREAM_SERIES_PRELOAD");
  ASSERT_TRUE(h);
  h->preload(1);
  EXPECT_FALSE(h->preload_ready(1));
  EXPECT_TRUE(h->set_series_position(1).ok());
  EXPECT_EQ(h->series_frame(), 1);
}

TEST_F(RenderHostSeries, TheLoadedCullingSceneRendersWhatARendererMakesItself) {
  auto h = open_host(series());
  ASSERT_TRUE(h);
  h->settings().cull = true;
  ASSERT_TRUE(h->recreate(64, 48).ok());
  h->preload(1);
  ASSERT_TRUE(wait_ready(*h, 1));
  ASSERT_TRUE(h->set_series_position(1).ok());  // the renderer of frame 1 takes the preloaded culling scene
  auto cam = render::default_view(0, h->view_bounds(), 40.0, 64.0 / 48.0);
  ASSERT_TRUE(cam.ok());
  auto with_loaded = h->renderer()->render(*cam);
  ASSERT_TRUE(with_loaded.ok()) << with_loaded.error().message;
  // The same scene, settings and density volume; the renderer makes its own culling scene.
  render::RenderSettings rs = h->settings();
  ASSERT_TRUE(rs.cull);
  auto vol = render::culling::density_from_store(h->reader(), *h->scene());
  ASSERT_TRUE(vol.ok());
  rs.density = std::make_shared<const render::culling::DensityVolume>(std::move(*vol));
  rs.cull_scene = nullptr;
  auto own = render::Renderer::create(*ctx_, *h->scene(), rs);
  ASSERT_TRUE(own.ok()) << own.error().message;
  auto with_own = (*own)->render(*cam);
  ASSERT_TRUE(with_own.ok());
  EXPECT_EQ(with_loaded->rgba, with_own->rgba);
  // A culling scene of another scene is refused.
  auto other = std::make_shared<render::culling::CullScene>();
  other->meshlet_slots = uint32_t(h->scene()->meshlets.size()) + 1;
  other->node_count = uint32_t(h->scene()->nodes.size());
  rs.cull_scene = other;
  auto refused = render::Renderer::create(*ctx_, *h->scene(), rs);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("cull_scene"), std::string::npos) << refused.error().message;
}

TEST_F(RenderHostSeries, AStreamingStepCarriesTheViewToTheNextFrame) {
  for (const bool carry : {true, false}) {
    auto h = open_host(series(), {}, 4 * fs::file_size(store(0)), carry);
    ASSERT_TRUE(h);
    ASSERT_TRUE(h->streaming());
    auto cam = render::default_view(0, h->view_bounds(), 40.0, 64.0 / 48.0);
    ASSERT_TRUE(cam.ok());
    ASSERT_TRUE(h->renderer()->set_view(*cam).ok());
    for (int i = 0; i < 60; ++i) {
      auto rep = h->renderer()->step();
      ASSERT_TRUE(rep.ok()) << rep.error().message;
      if (rep->settled) break;
    }
    const uint64_t wanted = h->renderer()->stats().cache.wanted_nodes;
    ASSERT_GT(wanted, 0u);
    ASSERT_TRUE(h->set_series_position(1).ok());
    const render::CacheStats c = h->renderer()->stats().cache;
    EXPECT_EQ(c.prior_wanted_nodes, carry ? wanted : 0u) << "carry " << carry;
    if (carry)
      EXPECT_GT(c.carried_nodes, 0u);
    else
      EXPECT_EQ(c.carried_nodes, 0u);
  }
}

}  // namespace
