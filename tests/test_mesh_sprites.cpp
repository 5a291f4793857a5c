// The task/mesh shader sprite path (render/mesh_sprites.h): mode parsing, run-time selection
// from the device, and -- on a device with VK_EXT_mesh_shader -- image parity with the compute
// + indirect draw path. Debian 12's lavapipe (Mesa 22.3) has no mesh shaders: there the parity
// test is skipped and the checks are that `auto` falls back and `on` is a clear error. Lavapipe
// of Mesa 25 (bookworm-backports) has them: tools/mesh_lavapipe.sh runs these tests there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <random>
#include <vector>

#include "render/camera.h"
#include "render/mesh_sprites.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render_test_helpers.h"
#include "vk/context.h"

using namespace mds;
using namespace mds::render;

namespace {

class MeshSpritesTest : public mds::testing::VulkanSuite {
 protected:
  // A dense random block of 20k particles of three types and radii, in meshlets of 16 and 40
  // (40 > kMeshParticles: two mesh workgroups per meshlet).
  static SceneData block(uint32_t meshlet_size) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 20.0);
    std::vector<glm::dvec3> pos(20000);
    std::vector<uint8_t> types(pos.size());
    for (size_t i = 0; i < pos.size(); ++i) {
      pos[i] = {u(rng), u(rng), u(rng)};
      types[i] = uint8_t(i % 3);
    }
    const float radii[3] = {0.5f, 0.35f, 0.8f};
    auto s = scene_from_particles(pos, types, radii, 4096, meshlet_size);
    EXPECT_TRUE(s.ok());
    return std::move(s).value();
  }

  static Result<FrameImage> render(const SceneData& scene, MeshShaderMode mode, bool cull, RenderStats* stats,
                                   bool visibility_route = true) {
    RenderSettings rs;
    rs.visibility_route = visibility_route;
    rs.width = 96;
    rs.height = 72;
    rs.spp = 4;
    rs.cull = cull;
    rs.mesh_shaders = mode;
    MDS_ASSIGN_OR_RETURN(auto r, Renderer::create(*ctx_, scene, rs));
    MDS_ASSIGN_OR_RETURN(Camera cam, default_view(1, scene.bounds, 40.0, 96.0 / 72.0));
    return r->render(cam, stats);
  }

};

}  // namespace

TEST(MeshShaderMode, Parses) {
  EXPECT_EQ(*parse_mesh_shader_mode("auto"), MeshShaderMode::automatic);
  EXPECT_EQ(*parse_mesh_shader_mode("on"), MeshShaderMode::on);
  EXPECT_EQ(*parse_mesh_shader_mode("off"), MeshShaderMode::off);
  auto bad = parse_mesh_shader_mode("yes");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("--mesh-shaders 'yes'"), std::string::npos) << bad.error().message;
  for (auto m : {MeshShaderMode::automatic, MeshShaderMode::on, MeshShaderMode::off})
    EXPECT_EQ(*parse_mesh_shader_mode(mesh_shader_mode_name(m)), m);
}

TEST_F(MeshSpritesTest, SelectionFollowsTheDevice) {
  // tools/mesh_lavapipe.sh sets this: a driver that should have mesh shaders and has none must
  // fail here rather than let the parity test skip.
  if (std::getenv("MDSTREAM_REQUIRE_MESH_SHADERS")) {
    EXPECT_TRUE(ctx_->mesh_shaders()) << ctx_->info().name << ": VK_EXT_mesh_shader expected";
  }
  EXPECT_FALSE(*use_mesh_sprites(*ctx_, MeshShaderMode::off));
  // auto: the compute path unless MDSTREAM_PREFER_MESH=1 (mesh_sprites.h: measured faster on a GPU).
  EXPECT_EQ(*use_mesh_sprites(*ctx_, MeshShaderMode::automatic), ctx_->mesh_shaders() && prefer_mesh_sprites());
  auto on = use_mesh_sprites(*ctx_, MeshShaderMode::on);
  EXPECT_EQ(on.ok(), ctx_->mesh_shaders());
  if (!on.ok()) {
    EXPECT_NE(on.error().message.find("VK_EXT_mesh_shader"), std::string::npos) << on.error().message;
    EXPECT_NE(on.error().message.find(ctx_->info().name), std::string::npos) << on.error().message;
  }
  // The context enables the extension exactly when the device lists it with both stages.
  if (!ctx_->info().mesh_shader) {
    EXPECT_FALSE(ctx_->mesh_shaders());
  }
}

TEST_F(MeshSpritesTest, RendererReportsThePathItTook) {
  SceneData scene = block(16);
  RenderStats st;
  auto img = render(scene, MeshShaderMode::automatic, false, &st);
  ASSERT_TRUE(img.ok()) << img.error().message;
  EXPECT_EQ(st.mesh_sprites, ctx_->mesh_shaders() && prefer_mesh_sprites());
  auto off = render(scene, MeshShaderMode::off, false, &st);
  ASSERT_TRUE(off.ok()) << off.error().message;
  EXPECT_FALSE(st.mesh_sprites);
  auto on = render(scene, MeshShaderMode::on, false, &st);
  EXPECT_EQ(on.ok(), ctx_->mesh_shaders());
}

// Same glyphs (include/sprite_make.h), same fragment shader: the two paths agree up to the
// order in which equal-depth fragments land, i.e. in a few pixels at most; on the visibility
// route (the mesh stage ray casting small glyphs) and on the attachment route alike.
TEST_F(MeshSpritesTest, MeshPathMatchesComputePath) {
  if (!ctx_->mesh_shaders()) GTEST_SKIP() << ctx_->info().name << " has no VK_EXT_mesh_shader";
  for (bool vis : {true, false}) {
    for (uint32_t meshlet_size : {16u, 40u}) {
      for (bool cull : {false, true}) {
        SCOPED_TRACE(::testing::Message() << "meshlet size " << meshlet_size << ", cull " << cull << ", visibility "
                                          << vis);
        SceneData scene = block(meshlet_size);
        RenderStats sm, sc;
        auto mesh = render(scene, MeshShaderMode::on, cull, &sm, vis);
        auto comp = render(scene, MeshShaderMode::off, cull, &sc);
        ASSERT_TRUE(mesh.ok()) << mesh.error().message;
        ASSERT_TRUE(comp.ok()) << comp.error().message;
        EXPECT_TRUE(sm.mesh_sprites);
        EXPECT_EQ(sm.visibility_route, vis && ctx_->int64_atomics());
        size_t differ = 0, covered = 0;
        for (size_t i = 0; i < mesh->rgba.size(); i += 4) {
          float d = 0.0f;
          for (int c = 0; c < 4; ++c) d = std::max(d, std::abs(mesh->rgba[i + c] - comp->rgba[i + c]));
          if (d > 2.0f / 255.0f) ++differ;
          if (comp->rgba[i + 3] > 0.0f) ++covered;
        }
        EXPECT_GT(covered, mesh->rgba.size() / 4 / 8);  // the view is not empty: over 1/8 of the pixels
        EXPECT_LE(differ, mesh->rgba.size() / 4 / 200) << differ << " pixels differ";  // <= 0.5 %
      }
    }
  }
}
