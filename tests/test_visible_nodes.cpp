// render/visible_nodes.h on real components: a porous store (synth -> convert), rendered in memory
// on lavapipe with one unjittered sample. The test is the definition of "the nodes that hold a
// visible particle": rendering only those nodes gives the same image, leaving out any one of
// them changes it, rendering only the others changes most covered pixels, and on a dense
// close-up they are a small part of the store.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "render/camera.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render/visible_nodes.h"
#include "render_test_helpers.h"
#include "store/store_reader.h"
#include "vk/context.h"

namespace fs = std::filesystem;
using namespace mds;
using namespace mds::render;

namespace {

constexpr uint32_t kW = 128, kH = 96;

// The store's nodes whose flag equals `keep`, as a scene with the store's bounds and types.
SceneData subset(const store::StoreReader& reader, const std::vector<uint8_t>& visible, uint8_t keep) {
  const store::FileHeader& h = reader.header();
  std::vector<float> radii;
  for (const auto& t : reader.types()) radii.push_back(t.radius);
  SceneData s = begin_scene({h.bounds_min[0], h.bounds_min[1], h.bounds_min[2]},
                            {h.bounds_max[0], h.bounds_max[1], h.bounds_max[2]}, radii,
                            (h.flags & store::kFlagPerParticleRadius) != 0, h.radius_min, h.radius_max);
  store::NodeData node;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < reader.nodes().size(); ++i) {
    if (visible[i] != keep) continue;
    EXPECT_TRUE(reader.read_node(i, node, scratch).ok());
    EXPECT_TRUE(append_node(s, reader.nodes()[i].center_min, reader.nodes()[i].center_max, node).ok());
  }
  return s;
}

}  // namespace

TEST(VisibleNodes, RenderingOnlyTheVisibleNodesGivesTheSameImage) {
  const fs::path dir = fs::temp_directory_path() / ("mds_visible_nodes_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string dump = (dir / "p.dump").string(), store = (dir / "p.mds").string();
  ASSERT_EQ(mds::testing::run_mdstream_quietly("synth --scene porous --particles 60000 -q -o " + dump), 0);
  ASSERT_EQ(mds::testing::run_mdstream_quietly("convert " + dump + " --node-size 500 -q -o " + store), 0);
  auto reader = store::StoreReader::open(store);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto ctx = vk::Context::create(vk::ContextOptions::from_env());
  ASSERT_TRUE(ctx.ok()) << ctx.error().message;
  auto full_scene = load_scene(**reader);
  ASSERT_TRUE(full_scene.ok());
  RenderSettings rs;
  rs.width = kW;
  rs.height = kH;
  rs.spp = 1;  // sample 0 is the pixel centre: one unjittered frame
  auto render = [&](const SceneData& scene, std::vector<float>* depth) {
    auto r = Renderer::create(**ctx, scene, rs);
    EXPECT_TRUE(r.ok()) << r.error().message;
    auto cam = default_view(2, scene.bounds, 40.0, double(kW) / kH);
    EXPECT_TRUE(cam.ok());
    auto img = (*r)->render(*cam);
    EXPECT_TRUE(img.ok()) << img.error().message;
    if (depth) *depth = *(*r)->read_last_depth();
    return *img;
  };
  std::vector<float> depth;
  const FrameImage full = render(*full_scene, &depth);
  auto cam = default_view(2, full_scene->bounds, 40.0, double(kW) / kH);
  ASSERT_TRUE(cam.ok());
  fit_clip_planes(*cam, full_scene->bounds);
  auto vis = visible_nodes(**reader, *cam, kW, kH, depth);
  ASSERT_TRUE(vis.ok()) << vis.error().message;
  size_t n = 0;
  for (uint8_t v : *vis) n += v;
  const size_t nodes = (*reader)->nodes().size();
  EXPECT_GT(n, 0u);
  EXPECT_LT(n, nodes / 2) << "a dense close-up sees a small part of the store";

  size_t covered = 0;
  for (float d : depth) covered += d < 1.0f;
  ASSERT_GT(covered, size_t(kW) * kH / 2);
  const FrameImage only_visible = render(subset(**reader, *vis, 1), nullptr);
  EXPECT_EQ(mds::testing::differing_pixels(full, only_visible, 1e-3f), 0u);
  const FrameImage only_hidden = render(subset(**reader, *vis, 0), nullptr);
  EXPECT_GT(mds::testing::differing_pixels(full, only_hidden, 1e-2f), covered / 2);

  // And none of them is there by the slack alone: without any one of them the image changes.
  for (uint32_t i = 0; i < vis->size(); ++i) {
    if (!(*vis)[i]) continue;
    std::vector<uint8_t> without = *vis;
    without[i] = 0;
    EXPECT_GT(mds::testing::differing_pixels(full, render(subset(**reader, without, 1), nullptr), 1e-3f), 0u)
        << "node " << i;
  }

  // Bad input is an error, not a crash.
  EXPECT_FALSE(visible_nodes(**reader, *cam, kW, kH, std::span<const float>(depth).first(10)).ok());
  fs::remove_all(dir);
}
