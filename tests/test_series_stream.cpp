// A streamed series step (StreamSettings::prior, docs/streaming.md "Series steps"): the cache of
// the next frame's store starts with one wave of the nodes that match, by box overlap, the nodes
// the view before wanted. On a real series (synth porous --frames 2, convert -o run.mds.series,
// nodes of <= 1000) and real Vulkan (lavapipe here, under the validation layer):
//  - the first frame's reads are exactly those nodes (every one of them: the whole block is in
//    view and the pool holds the store), more than a cold cache's first wave;
//  - view 2 converges to the image a cold cache converges to, in fewer frames (5 against 202
//    when this was written: the cold cache's waves from the front read 236 nodes a few at a time);
//  - a prior view whose boxes lie elsewhere carries nothing: the cold cache's first wave.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "render/camera.h"
#include "render/renderer.h"
#include "render/streaming/stream_cache.h"
#include "render_test_helpers.h"
#include "scoped_temp_dir.h"
#include "store/store_reader.h"
#include "streaming/node_match.h"

namespace fs = std::filesystem;
using namespace mds;
using namespace mds::render;

namespace {

constexpr uint32_t kW = 160, kH = 120;

class SeriesStream : public mds::testing::VulkanSuite {
 protected:
  static void SetUpTestSuite() {
    VulkanSuite::SetUpTestSuite();
    dir_ = new mds::test::ScopedTempDir("mds_series_stream_");
    const fs::path dump = dir_->p / "porous.lammpstrj";
    ASSERT_EQ(mds::testing::run_mdstream_quietly("synth --scene porous -n 200000 --frames 2 -q -o " + dump.string()), 0);
    ASSERT_EQ(mds::testing::run_mdstream_quietly("convert " + dump.string() + " --node-size 1000 -q -o " +
                                                 (dir_->p / "run.mds.series").string()),
              0);
    for (int k = 0; k < 2; ++k) {
      auto r = store::StoreReader::open(dir_->p / ("run.000" + std::to_string(k) + ".mds"));
      ASSERT_TRUE(r.ok()) << r.error().message;
      readers_[k] = r->release();
    }
  }
  static void TearDownTestSuite() {
    for (auto*& r : readers_) delete r, r = nullptr;
    delete dir_;
    dir_ = nullptr;
    VulkanSuite::TearDownTestSuite();
  }
  static const store::StoreReader& frame(int k) { return *readers_[k]; }
  static uint64_t store_bytes(int k) { return fs::file_size(frame(k).path()); }

  static RenderSettings settings() {
    RenderSettings rs;
    rs.width = kW;
    rs.height = kH;
    rs.spp = 2;
    return rs;
  }
  // View `index` of the bounds of both frames (the series' camera: one for every frame).
  static Camera view(int index) {
    Bounds b;
    b.min = glm::dvec3(1e300);
    b.max = glm::dvec3(-1e300);
    for (int k = 0; k < 2; ++k) {
      const store::FileHeader& h = frame(k).header();
      b.min = glm::min(b.min, glm::dvec3(h.bounds_min[0], h.bounds_min[1], h.bounds_min[2]));
      b.max = glm::max(b.max, glm::dvec3(h.bounds_max[0], h.bounds_max[1], h.bounds_max[2]));
      for (const auto& t : frame(k).types()) b.radius_max = std::max(b.radius_max, double(t.radius));
    }
    auto cam = default_view(index, b, 40.0, double(kW) / kH);
    EXPECT_TRUE(cam.ok());
    return cam.value();
  }
  static std::unique_ptr<Renderer> streaming_renderer(int k, uint64_t budget,
                                                      std::shared_ptr<const streaming::PriorView> prior = nullptr) {
    StreamSettings ss;
    ss.gpu_budget = budget;
    ss.prior = std::move(prior);
    auto r = Renderer::create_streaming(*ctx_, frame(k), settings(), ss);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
    return r.ok() ? std::move(*r) : nullptr;
  }
  // Frame 0 rendered to convergence at `view_index`; what its cache knew of the view.
  static std::shared_ptr<const streaming::PriorView> prior_of_frame0(int view_index, uint64_t budget) {
    auto r = streaming_renderer(0, budget);
    if (!r) return nullptr;
    auto img = r->render(view(view_index));
    EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error().message);
    return r->prior_view();
  }
  // Reads the first frame of a fresh view requests.
  static uint32_t first_reads(Renderer& r, const Camera& cam) {
    EXPECT_TRUE(r.set_view(cam).ok());
    auto rep = r.step();
    EXPECT_TRUE(rep.ok()) << (rep.ok() ? "" : rep.error().message);
    return rep.ok() ? rep->reads_requested : 0;
  }

  static inline mds::test::ScopedTempDir* dir_ = nullptr;
  static inline store::StoreReader* readers_[2] = {nullptr, nullptr};
};

TEST_F(SeriesStream, TheFirstWaveIsTheNodesTheFrameBeforeWanted) {
  const uint64_t budget = 4 * store_bytes(1);  // the pool holds every node (~11 B a particle against ~6 on disk)
  auto prior = prior_of_frame0(0, budget);
  ASSERT_TRUE(prior);
  ASSERT_EQ(prior->boxes.size(), frame(0).nodes().size());
  EXPECT_GT(prior->wanted_count(), 0u);
  const std::vector<uint8_t> carried =
      streaming::carried_wanted(*prior, streaming::node_boxes(frame(1)), streaming_gpu::StreamCache::kPriorMinIou);
  const auto n_carried = uint32_t(std::count(carried.begin(), carried.end(), uint8_t(1)));
  EXPECT_GT(n_carried, prior->wanted_count() / 2) << "the nodes of the next frame are nearly where they were";

  auto warm = streaming_renderer(1, budget, prior);
  auto cold = streaming_renderer(1, budget);
  ASSERT_TRUE(warm && cold);
  const uint32_t warm_reads = first_reads(*warm, view(0)), cold_reads = first_reads(*cold, view(0));
  EXPECT_EQ(warm_reads, n_carried) << "the whole block is in view: every carried node is read at once";
  EXPECT_LT(cold_reads, warm_reads);
  EXPECT_EQ(warm->stats().cache.carried_nodes, n_carried);
  EXPECT_EQ(warm->stats().cache.prior_wanted_nodes, prior->wanted_count());
  EXPECT_EQ(cold->stats().cache.carried_nodes, 0u);
}

TEST_F(SeriesStream, ACarriedStartConvergesToTheColdImageInFewerFrames) {
  const uint64_t budget = 4 * store_bytes(1);
  auto prior = prior_of_frame0(2, budget);
  ASSERT_TRUE(prior);
  auto warm = streaming_renderer(1, budget, prior);
  auto cold = streaming_renderer(1, budget);
  ASSERT_TRUE(warm && cold);
  RenderStats ws, cs;
  auto wi = warm->render(view(2), &ws);
  auto ci = cold->render(view(2), &cs);
  ASSERT_TRUE(wi.ok() && ci.ok());
  EXPECT_GT(ws.cache.carried_nodes, 0u);
  EXPECT_FALSE(ws.cache.budget_exhausted);
  EXPECT_FALSE(cs.cache.budget_exhausted);
  EXPECT_LE(ws.cache.gpu_peak_bytes, ws.cache.gpu_budget_bytes);
  // The same converged view: within the renderer's tolerance (culled vs unculled: <= 1 % of the pixels).
  EXPECT_LE(mds::testing::differing_pixels(*wi, *ci), size_t(kW) * kH / 100);
  ASSERT_GT(ws.cache.frames_to_complete, 0u);
  ASSERT_GT(cs.cache.frames_to_complete, 0u);
  EXPECT_LT(ws.cache.frames_to_complete, cs.cache.frames_to_complete)
      << "one wave of the nodes seen before, against waves from the front";
}

TEST_F(SeriesStream, APriorViewElsewhereCarriesNothing) {
  const uint64_t budget = 4 * store_bytes(1);
  auto prior = prior_of_frame0(0, budget);
  ASSERT_TRUE(prior);
  auto moved = std::make_shared<streaming::PriorView>(*prior);
  for (streaming::NodeBox& b : moved->boxes) b.lo += glm::dvec3(1e4), b.hi += glm::dvec3(1e4);
  auto warm = streaming_renderer(1, budget, moved);
  auto cold = streaming_renderer(1, budget);
  ASSERT_TRUE(warm && cold);
  EXPECT_EQ(warm->stats().cache.carried_nodes, 0u);
  EXPECT_EQ(warm->stats().cache.prior_wanted_nodes, prior->wanted_count());
  EXPECT_EQ(first_reads(*warm, view(0)), first_reads(*cold, view(0)));
}

}  // namespace
