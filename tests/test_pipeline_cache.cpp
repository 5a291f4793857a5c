// vk::PipelineCache (vk/pipeline_cache.h) on the real device (lavapipe here), with the Khronos
// validation layer where installed:
//  - layouts are shared by definition (bindings and push constant size), pipelines by layout,
//    shader and specialization; a different definition or constant makes a new one;
//  - a second renderer in the same context makes no pipeline and renders bit for bit what the
//    first rendered; a renderer of another scene on pipelines made for the first renders what it
//    renders in a fresh context (the pipelines carry nothing of the scene they were made for);
//  - MDSTREAM_PIPELINE_REUSE=0 (the A/B switch of tools/bench_series_render.py) makes every
//    request anew.
#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "render/camera.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render_test_helpers.h"
#include "vk/context.h"
#include "vk/pipeline.h"
#include "vk/pipeline_cache.h"

using namespace mds;
using namespace mds::render;

namespace {

constexpr uint32_t kW = 96, kH = 72;

SceneData block(size_t n, uint64_t seed) {
  const std::vector<glm::dvec3> pos = mds::testing::dense_block_positions(n, seed);
  std::vector<uint8_t> types(pos.size());
  for (size_t i = 0; i < types.size(); ++i) types[i] = uint8_t(i % 2);
  const float radius[2] = {0.5f, 0.7f};
  auto s = scene_from_particles(pos, types, radius, 1000, 16);
  EXPECT_TRUE(s.ok());
  return std::move(s.value());
}

FrameImage render_once(vk::Context& ctx, const SceneData& scene) {
  RenderSettings rs;
  rs.width = kW;
  rs.height = kH;
  rs.spp = 4;
  rs.cull = true;
  auto r = Renderer::create(ctx, scene, rs);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  if (!r.ok()) return {};
  auto cam = default_view(0, scene.bounds, 40.0, double(kW) / kH);
  EXPECT_TRUE(cam.ok());
  auto img = r.value()->render(cam.value());
  EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error().message);
  return img.ok() ? std::move(img.value()) : FrameImage{};
}

bool same_pixels(const FrameImage& a, const FrameImage& b) {
  return a.width == b.width && a.height == b.height && !a.rgba.empty() && a.rgba == b.rgba;
}

vk::DescriptorSet make_set(vk::Context& ctx, std::vector<VkDescriptorType> types) {
  std::vector<VkDescriptorSetLayoutBinding> b;
  for (uint32_t i = 0; i < types.size(); ++i) b.push_back({i, types[i], 1, VK_SHADER_STAGE_ALL, nullptr});
  auto s = vk::DescriptorSet::create(ctx.device(), b);
  EXPECT_TRUE(s.ok());
  return std::move(s.value());
}

class PipelineCacheTest : public mds::testing::VulkanSuite {};

TEST_F(PipelineCacheTest, SharedByDefinition) {
  // test_saxpy.comp: two storage buffers in set 0, a 4-byte push constant, kA (id 0).
  vk::PipelineCache& cache = ctx_->pipelines();
  const VkDescriptorType SSBO = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, UBO = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  vk::DescriptorSet a = make_set(*ctx_, {SSBO, SSBO}), b = make_set(*ctx_, {SSBO, SSBO}),
                    c = make_set(*ctx_, {SSBO, SSBO, UBO});
  const vk::DescriptorSet* sa[] = {&a};
  const vk::DescriptorSet* sb[] = {&b};
  const vk::DescriptorSet* sc[] = {&c};
  auto la = cache.layout(sa, 4), lb = cache.layout(sb, 4), lc = cache.layout(sc, 4), ld = cache.layout(sa, 8);
  ASSERT_TRUE(la.ok() && lb.ok() && lc.ok() && ld.ok());
  EXPECT_EQ(*la, *lb) << "identically defined sets share a layout";
  EXPECT_NE(*la, *lc) << "another binding";
  EXPECT_NE(*la, *ld) << "another push constant size";

  const vk::PipelineCache::Counts before = cache.counts();
  vk::SpecConstants s1, s2, s1_again;
  s1.add(0u, 2.0f);
  s2.add(0u, 3.0f);
  s1_again.add(0u, 2.0f);
  auto p1 = cache.compute(*la, "test_saxpy.comp", &s1);
  auto p1_again = cache.compute(*lb, "test_saxpy.comp", &s1_again);
  auto p2 = cache.compute(*la, "test_saxpy.comp", &s2);
  auto p3 = cache.compute(*lc, "test_saxpy.comp", &s1);
  ASSERT_TRUE(p1.ok() && p1_again.ok() && p2.ok() && p3.ok()) << (p1.ok() ? "" : p1.error().message);
  EXPECT_EQ(*p1, *p1_again);
  EXPECT_NE(*p1, *p2) << "another specialization";
  EXPECT_NE(*p1, *p3) << "another layout";
  const vk::PipelineCache::Counts after = cache.counts();
  EXPECT_EQ(after.pipelines, before.pipelines + 3);
  EXPECT_EQ(after.reused, before.reused + 1);
  auto missing = cache.compute(*la, "no_such_shader.comp");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("no_such_shader.comp"), std::string::npos) << missing.error().message;
  EXPECT_EQ(cache.counts().pipelines, after.pipelines) << "a failed request keeps nothing";
}

TEST_F(PipelineCacheTest, NextRendererMakesNoPipelineAndRendersTheSame) {
  const SceneData scene = block(20000, 3);
  const FrameImage first = render_once(*ctx_, scene);
  const vk::PipelineCache::Counts made = ctx_->pipelines().counts();
  EXPECT_GT(made.pipelines, 5u);
  const FrameImage second = render_once(*ctx_, scene);
  const vk::PipelineCache::Counts again = ctx_->pipelines().counts();
  EXPECT_EQ(again.pipelines, made.pipelines) << "the second renderer compiled a pipeline";
  EXPECT_EQ(again.layouts, made.layouts);
  EXPECT_GT(again.reused, made.reused);
  EXPECT_TRUE(same_pixels(first, second));
}

TEST_F(PipelineCacheTest, AnotherSceneOnReusedPipelinesRendersAsInAFreshContext) {
  const SceneData a = block(20000, 3), b = block(12000, 11);  // other counts, bounds, radii order
  (void)render_once(*ctx_, a);
  const uint64_t made = ctx_->pipelines().counts().pipelines;
  const FrameImage reused = render_once(*ctx_, b);
  EXPECT_EQ(ctx_->pipelines().counts().pipelines, made);
  auto fresh_ctx = vk::Context::create(vk::ContextOptions{});
  ASSERT_TRUE(fresh_ctx.ok()) << fresh_ctx.error().message;
  const FrameImage fresh = render_once(**fresh_ctx, b);
  EXPECT_EQ((*fresh_ctx)->pipelines().counts().reused, 0u);
  EXPECT_TRUE(same_pixels(reused, fresh));
}

TEST(PipelineCacheReuseOff, EveryRequestMakesANewPipeline) {
  setenv("MDSTREAM_PIPELINE_REUSE", "0", 1);
  auto ctx = vk::Context::create(vk::ContextOptions{});
  unsetenv("MDSTREAM_PIPELINE_REUSE");
  ASSERT_TRUE(ctx.ok()) << ctx.error().message;
  const SceneData scene = block(8000, 5);
  const FrameImage first = render_once(**ctx, scene);
  const vk::PipelineCache::Counts made = (*ctx)->pipelines().counts();
  const FrameImage second = render_once(**ctx, scene);
  const vk::PipelineCache::Counts again = (*ctx)->pipelines().counts();
  EXPECT_EQ(again.reused, 0u);
  EXPECT_EQ(again.pipelines, 2 * made.pipelines);
  EXPECT_EQ(again.layouts, 2 * made.layouts);
  EXPECT_TRUE(same_pixels(first, second));
}

}  // namespace
