// The two sprite routes of the renderer (renderer_impl.h) give the same image and depth:
// the visibility route (one uint64 of depth bits and sprite index per pixel, written by the
// compute rasterization of small sprites and by the rasterized ones, each pixel shaded once by
// visibility_resolve.comp) and the attachment route (colour + depth attachments, the route of
// devices without 64-bit buffer atomics; tests/test_mesh_sprites.cpp covers the mesh path's). Within the visibility route the
// small-sprite threshold (MDSTREAM_SMALL_PX) only moves sprites between compute and the
// rasterizer, so every threshold must give the same image too. Where the samples are summed
// (a storage buffer, or the storage image used where the buffer exceeds maxStorageBufferRange)
// must not change a bit of the image on either route. Sprite records that hold fewer sprites than
// the draw list has particles make the renderer draw the list in chunks: the same image again.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "render/camera.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render_test_helpers.h"
#include "vk/context.h"

using namespace mds;
using namespace mds::render;

namespace {

class SpriteRoutesTest : public mds::testing::VulkanSuite {
 protected:
  // A dense random block of 60k particles of three types and radii in compact meshlets (as
  // test_cull_render.cpp's, front blocks first): sprites of a few pixels at 96x72, many overlaps,
  // and a view 0 that culls.
  static SceneData block() {
    const std::vector<glm::dvec3> pos = mds::testing::dense_block_positions(60000, 11);
    std::vector<uint8_t> types(pos.size());
    for (size_t i = 0; i < pos.size(); ++i) types[i] = uint8_t(i % 3);
    const float radii[3] = {0.5f, 0.35f, 0.8f};
    auto s = scene_from_particles(pos, types, radii, 2000, 16);
    EXPECT_TRUE(s.ok());
    return std::move(s).value();
  }

  using Out = mds::testing::RenderedFrame;

  // small_px: MDSTREAM_SMALL_PX for this renderer (nullptr: the default threshold).
  static Result<Out> render(const SceneData& scene, bool visibility_route, const char* small_px, bool cull,
                            bool accumulation_buffer = true, bool covered_pixel_list = true,
                            double covered_list_max_coverage = 1.0, uint64_t sprite_capacity = 0,
                            bool own_colors = false) {
    if (small_px) {
      setenv("MDSTREAM_SMALL_PX", small_px, 1);
    } else {
      unsetenv("MDSTREAM_SMALL_PX");
    }
    RenderSettings rs;
    rs.width = 96;
    rs.height = 72;
    rs.spp = 4;
    rs.cull = cull;
    rs.mesh_shaders = MeshShaderMode::off;
    rs.visibility_route = visibility_route;
    rs.accumulation_buffer = accumulation_buffer;
    rs.covered_pixel_list = covered_pixel_list;
    rs.covered_list_max_coverage = covered_list_max_coverage;  // default 1.0: every frame through the list
    rs.sprite_capacity = sprite_capacity;
    rs.color_by.particle_colors = own_colors;  // the scene's SceneData::color (--color-by color)
    auto r = Renderer::create(*ctx_, scene, rs);
    unsetenv("MDSTREAM_SMALL_PX");  // read once, by create()
    if (!r.ok()) return r.error();
    MDS_ASSIGN_OR_RETURN(Camera cam, default_view(0, scene.bounds, 40.0, 96.0 / 72.0));
    Out out;
    MDS_ASSIGN_OR_RETURN(out.image, (*r)->render(cam, &out.stats));
    MDS_ASSIGN_OR_RETURN(out.depth, (*r)->read_last_depth());
    return out;
  }

  static size_t differing_depths(const std::vector<float>& a, const std::vector<float>& b) {
    size_t n = 0;
    for (size_t i = 0; i < a.size(); ++i)
      if (std::abs(a[i] - b[i]) > 1e-6f) ++n;
    return n;
  }
};

}  // namespace

TEST_F(SpriteRoutesTest, VisibilityRouteMatchesAttachmentRoute) {
  if (!ctx_->int64_atomics()) GTEST_SKIP() << ctx_->info().name << " has no 64-bit buffer atomics";
  const SceneData scene = block();
  auto att = render(scene, false, nullptr, false);
  ASSERT_TRUE(att.ok()) << att.error().message;
  // The route each renderer took shows in its passes: "resolve" only on the visibility route.
  EXPECT_TRUE(att->stats.pass_ms_median.count("accumulate"));
  EXPECT_FALSE(att->stats.pass_ms_median.count("resolve"));
  size_t covered = 0;
  for (float d : att->depth) covered += d < 1.0f;
  ASSERT_GT(covered, att->depth.size() / 2) << "the block must cover most of the image";

  // Default threshold (mostly compute-rasterized), 0 (everything through the rasterizer into
  // the visibility buffer) and 1000 (everything in compute).
  for (const char* small_px : {static_cast<const char*>(nullptr), "0", "1000"}) {
    SCOPED_TRACE(small_px ? small_px : "default");
    auto vis = render(scene, true, small_px, false);
    ASSERT_TRUE(vis.ok()) << vis.error().message;
    EXPECT_TRUE(vis->stats.pass_ms_median.count("resolve"));
    EXPECT_FALSE(vis->stats.pass_ms_median.count("accumulate"));
    // Same rays, same shading: only pixels where two spheres meet at equal depth may pick a
    // different one (the visibility route takes the smaller index, the depth test the first
    // drawn). At most 0.5 % of the 6912 pixels, and the same depth everywhere but there.
    EXPECT_LE(mds::testing::differing_pixels(att->image, vis->image, 0.02f), 35u);
    EXPECT_LE(differing_depths(att->depth, vis->depth), 35u);
  }
}

TEST_F(SpriteRoutesTest, CulledRendersAgreeAcrossRoutes) {
  if (!ctx_->int64_atomics()) GTEST_SKIP() << ctx_->info().name << " has no 64-bit buffer atomics";
  const SceneData scene = block();
  auto att = render(scene, false, nullptr, true);
  auto vis = render(scene, true, nullptr, true);
  ASSERT_TRUE(att.ok()) << att.error().message;
  ASSERT_TRUE(vis.ok()) << vis.error().message;
  // The culling loop does not depend on the route: the same classes, the same image.
  EXPECT_EQ(att->stats.cull.meshlets_culled, vis->stats.cull.meshlets_culled);
  EXPECT_GT(vis->stats.cull.meshlets_culled, 0u);
  EXPECT_LE(mds::testing::differing_pixels(att->image, vis->image, 0.02f), 35u);
}

// The resolve over the compacted covered pixels and the full-screen resolve shade the same pixels
// with the same sums; the background is composed on the host in both cases.
TEST_F(SpriteRoutesTest, CoveredPixelListMatchesFullScreenResolve) {
  if (!ctx_->int64_atomics()) GTEST_SKIP() << ctx_->info().name << " has no 64-bit buffer atomics";
  if (!ctx_->compute_ballot()) GTEST_SKIP() << ctx_->info().name << " has no subgroup ballots in compute";
  const SceneData scene = block();
  for (bool cull : {false, true}) {
    SCOPED_TRACE(cull ? "culled" : "no cull");
    auto list = render(scene, true, nullptr, cull, true, true);
    auto full = render(scene, true, nullptr, cull, true, false);
    ASSERT_TRUE(list.ok()) << list.error().message;
    ASSERT_TRUE(full.ok()) << full.error().message;
    EXPECT_TRUE(list->stats.covered_pixel_list);
    EXPECT_FALSE(full->stats.covered_pixel_list);
    ASSERT_EQ(list->image.rgba.size(), full->image.rgba.size());
    EXPECT_EQ(list->image.rgba, full->image.rgba);  // per pixel the same samples in the same order
    // Both covered and background pixels, so a list that dropped or duplicated pixels would show.
    size_t covered = 0, empty = 0;
    for (size_t i = 3; i < list->image.rgba.size(); i += 4) {
      covered += list->image.rgba[i] > 0.0f;
      empty += list->image.rgba[i] == 0.0f;
    }
    EXPECT_GT(covered, 0u);
    EXPECT_GT(empty, 0u);
    // The view's probe counted the covered pixels of its first sample; the image holds the union
    // over all samples. The full-screen render has no list, so no probe.
    EXPECT_GT(list->stats.covered_fraction, 0.0);
    EXPECT_LE(list->stats.covered_fraction, double(covered) / double(covered + empty) + 1e-12);
    EXPECT_EQ(full->stats.covered_fraction, -1.0);
    // Above the threshold the frames after the probe take the full-screen resolve: the same image.
    auto chosen = render(scene, true, nullptr, cull, true, true, list->stats.covered_fraction / 2.0);
    ASSERT_TRUE(chosen.ok()) << chosen.error().message;
    EXPECT_FALSE(chosen->stats.covered_pixel_list);
    EXPECT_EQ(chosen->stats.covered_fraction, list->stats.covered_fraction);
    EXPECT_EQ(chosen->image.rgba, full->image.rgba);
  }
}

TEST_F(SpriteRoutesTest, AccumulationBufferAndImageGiveTheSameImage) {
  const SceneData scene = block();
  for (bool vis_route : {false, true}) {
    if (vis_route && !ctx_->int64_atomics()) continue;
    SCOPED_TRACE(vis_route ? "visibility route" : "attachment route");
    auto buf = render(scene, vis_route, nullptr, false, true);
    auto img = render(scene, vis_route, nullptr, false, false);
    ASSERT_TRUE(buf.ok()) << buf.error().message;
    ASSERT_TRUE(img.ok()) << img.error().message;
    EXPECT_TRUE(buf->stats.accumulation_buffer);  // 96x72x16 B is far below any storage buffer range
    EXPECT_FALSE(img->stats.accumulation_buffer);
    EXPECT_EQ(buf->stats.visibility_route, vis_route);
    // The same sums in the same order: identical floats.
    ASSERT_EQ(buf->image.rgba.size(), img->image.rgba.size());
    EXPECT_EQ(buf->image.rgba, img->image.rgba);
    size_t covered = 0;
    for (size_t i = 3; i < buf->image.rgba.size(); i += 4) covered += buf->image.rgba[i] > 0.0f;
    EXPECT_GT(covered, buf->image.rgba.size() / 8) << "most pixels must hold spheres";
  }
}

// Sprite records for 2000 sprites (the block's list has up to 60000 particles): the list is made
// into sprites and drawn in chunks of 125 meshlets. The visibility route keeps each pixel's
// nearest particle by depth and frame-wide id whatever the chunk, and the resolve rebuilds that
// particle's sphere: identical floats. The attachment route draws the chunks in list order over
// the same depth buffer: only equal-depth ties may differ.
// The particles' own colours (SceneData::color) through chunked draws: the visibility route's
// resolve then rebuilds each winner from its frame-wide id (sprite_make.h mds_vis_id_sphere,
// which also reads its colour) instead of its sprite record, and must give the image of one
// chunk, whose resolve reads GpuSprite.color. Fails when either path loses the colour.
TEST_F(SpriteRoutesTest, OwnColoursDrawnInChunksGiveTheSameImage) {
  if (!ctx_->int64_atomics()) GTEST_SKIP() << ctx_->info().name << " has no 64-bit buffer atomics";
  SceneData scene = block();
  scene.has_color = true;
  scene.color.resize(scene.particle_count());
  for (size_t i = 0; i < scene.color.size(); ++i)
    scene.color[i] = uint32_t((i * 37) % 256 | ((i * 91) % 256) << 8 | ((i * 13) % 256) << 16 | 0xffu << 24);
  auto whole = render(scene, true, nullptr, false, true, true, 1.0, 0, true);
  auto chunks = render(scene, true, nullptr, false, true, true, 1.0, 2000, true);
  auto typed = render(scene, true, nullptr, false);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  ASSERT_TRUE(chunks.ok()) << chunks.error().message;
  ASSERT_TRUE(typed.ok()) << typed.error().message;
  EXPECT_EQ(whole->stats.sprite_chunks, 1u);
  EXPECT_GE(chunks->stats.sprite_chunks, 30u);
  EXPECT_EQ(chunks->image.rgba, whole->image.rgba);
  EXPECT_GT(mds::testing::differing_pixels(whole->image, typed->image, 0.05f), whole->image.rgba.size() / 32);
}

TEST_F(SpriteRoutesTest, SpritesDrawnInChunksGiveTheSameImage) {
  const SceneData scene = block();
  for (bool vis_route : {true, false}) {
    if (vis_route && !ctx_->int64_atomics()) continue;
    for (bool cull : {false, true}) {
      for (const char* small_px : {static_cast<const char*>(nullptr), "0"}) {
        if (!vis_route && small_px) continue;  // no compute rasterization on the attachment route
        SCOPED_TRACE(std::string(vis_route ? "visibility route" : "attachment route") + (cull ? ", culled" : "") +
                     (small_px ? ", small px 0" : ""));
        auto whole = render(scene, vis_route, small_px, cull);
        auto chunks = render(scene, vis_route, small_px, cull, true, true, 1.0, 2000);
        ASSERT_TRUE(whole.ok()) << whole.error().message;
        ASSERT_TRUE(chunks.ok()) << chunks.error().message;
        EXPECT_EQ(whole->stats.sprite_chunks, 1u);
        EXPECT_GE(chunks->stats.sprite_chunks, 30u);  // ceil(3750 meshlets / 125)
        // The frame-wide counters add up over the chunks.
        EXPECT_EQ(chunks->stats.sprites_listed, whole->stats.sprites_listed);
        EXPECT_GT(whole->stats.sprites_listed, 2000u);
        EXPECT_EQ(chunks->stats.sprites_offscreen, whole->stats.sprites_offscreen);
        EXPECT_EQ(chunks->stats.sprites_small, whole->stats.sprites_small);
        if (cull) {
          EXPECT_EQ(chunks->stats.cull.meshlets_culled, whole->stats.cull.meshlets_culled);
          EXPECT_EQ(chunks->stats.cull.particles_listed, whole->stats.cull.particles_listed);
          EXPECT_EQ(chunks->stats.cull.particles_occluded, whole->stats.cull.particles_occluded);
        }
        ASSERT_EQ(chunks->image.rgba.size(), whole->image.rgba.size());
        if (vis_route) {
          EXPECT_EQ(chunks->image.rgba, whole->image.rgba);
          EXPECT_EQ(chunks->depth, whole->depth);
        } else {
          EXPECT_LE(mds::testing::differing_pixels(chunks->image, whole->image, 0.02f), 35u);
          EXPECT_LE(differing_depths(chunks->depth, whole->depth), 35u);
        }
        size_t covered = 0;
        for (size_t i = 3; i < chunks->image.rgba.size(); i += 4) covered += chunks->image.rgba[i] > 0.0f;
        EXPECT_GT(covered, chunks->image.rgba.size() / 8);
      }
    }
  }
}

