// The GPU culling loop end to end (render/culling/cull_loop.h inside the renderer) on the real
// Vulkan device (lavapipe here), on a dense block of spheres whose front layers hide the rest:
// culled renders match --no-cull renders, the probabilistic acceptance culls more than the 50:50
// coin, and classes only move upward during one view.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "render/camera.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render_test_helpers.h"
#include "vk/context.h"

using namespace mds;
using namespace mds::render;

namespace {

constexpr uint32_t kW = 120, kH = 90;

// A culled render of spp samples at kW x kH.
RenderSettings culled_settings(uint32_t spp) {
  RenderSettings rs;
  rs.width = kW;
  rs.height = kH;
  rs.spp = spp;
  rs.cull = true;
  return rs;
}

// A dense block: 60000 spheres of radius 0.5 uniformly in a 20^3 cube (packing fraction ~0.4),
// ordered in compact blocks, so front meshlets occlude back ones. Seeded: same scene every run.
SceneData dense_block() {
  const std::vector<glm::dvec3> pos = mds::testing::dense_block_positions(60000, 7);
  std::vector<uint8_t> types(pos.size());
  for (size_t i = 0; i < types.size(); ++i) types[i] = uint8_t(i % 2);
  const float radius[2] = {0.5f, 0.5f};
  auto s = scene_from_particles(pos, types, radius, 2000, 16);
  EXPECT_TRUE(s.ok());
  return std::move(s.value());
}

struct RenderRun {
  FrameImage image;
  RenderStats stats;
  std::vector<std::vector<uint32_t>> classes;  // per iteration
};

RenderRun render_scene(vk::Context& ctx, const SceneData& scene, bool cull, int acceptance, uint32_t spp,
                 bool record_classes = false, uint32_t samples_per_iteration = 0, uint32_t paired_frames = 0,
                 culling::SampleRoute sample_route = culling::SampleRoute::automatic, double closer = 1.0,
                 bool particle_occlusion = true, bool sampled_pixel_list = true,
                 MeshShaderMode mesh_shaders = MeshShaderMode::automatic) {
  RenderSettings rs;
  rs.mesh_shaders = mesh_shaders;
  rs.particle_occlusion = particle_occlusion;
  rs.cull_settings.sampled_pixel_list = sampled_pixel_list;
  rs.cull_settings.sample_route = sample_route;
  rs.paired_frames = paired_frames;
  rs.width = kW;
  rs.height = kH;
  rs.spp = spp;
  rs.cull = cull;
  rs.cull_settings.acceptance = acceptance;
  if (samples_per_iteration > 0) rs.cull_settings.samples_per_iteration = samples_per_iteration;
  auto r = Renderer::create(ctx, scene, rs);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  RenderRun run;
  if (record_classes)
    r.value()->set_iteration_hook([&](uint32_t) {
      auto c = r.value()->cull_loop()->read_meshlet_classes();
      ASSERT_TRUE(c.ok());
      run.classes.push_back(c.value());
    });
  auto cam = default_view(0, scene.bounds, 40.0, double(kW) / kH);
  EXPECT_TRUE(cam.ok());
  // closer < 1: the eye moved toward the target (a close-up: glyphs of hundreds of pixels).
  cam.value().eye = cam.value().target + (cam.value().eye - cam.value().target) * closer;
  auto img = r.value()->render(cam.value(), &run.stats);
  EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error().message);
  run.image = std::move(img.value());
  return run;
}

double culled_fraction(const RenderRun& r) { return double(r.stats.cull.meshlets_culled) / double(r.stats.meshlets); }

class CullRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto c = vk::Context::create(vk::ContextOptions::from_env());
    ASSERT_TRUE(c.ok()) << c.error().message;
    ctx_ = std::move(c.value());
    scene_ = new SceneData(dense_block());
  }
  static void TearDownTestSuite() {
    delete scene_;
    ctx_.reset();
  }
  static std::unique_ptr<vk::Context> ctx_;
  static SceneData* scene_;
};
std::unique_ptr<vk::Context> CullRender::ctx_;
SceneData* CullRender::scene_ = nullptr;

TEST_F(CullRender, CulledRenderMatchesNoCull) {
  const uint32_t spp = 24;
  RenderRun ref = render_scene(*ctx_, *scene_, false, MDS_CULL_ACCEPT_NORMAL, spp);
  RenderRun cul = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, spp);
  // The view must actually cull (a dense block seen from the front hides most of its meshlets).
  EXPECT_GT(culled_fraction(cul), 0.4) << "culled " << cul.stats.cull.meshlets_culled;
  // Same spp, same jitter sequence: the images differ only where a culled meshlet was visible
  // in some samples. O requires confidence > C_occ = 0.95 over the meshlet's pixels, so at most
  // ~5 % of sub-pixel area behind a culled box may be uncovered; over the (few) culled boxes at
  // the silhouette that leaves a small set of pixels. Bound: a colour difference > 0.1 in at
  // most 1 % of the pixels (measured: well below; the culled run also drew the meshlets it culled
  // later in its first iterations, which does not change the average where they are hidden).
  size_t differ = 0;
  for (uint32_t y = 0; y < kH; ++y)
    for (uint32_t x = 0; x < kW; ++x) {
      glm::vec4 a = ref.image.at(x, y), b = cul.image.at(x, y);
      float d = std::max({std::abs(a.r - b.r), std::abs(a.g - b.g), std::abs(a.b - b.b)});
      if (d > 0.1f) ++differ;
    }
  EXPECT_LE(differ, size_t(kW * kH / 100)) << "culled fraction " << culled_fraction(cul);
}

TEST_F(CullRender, ProbabilisticAcceptanceCullsMoreThanRandom) {
  const uint32_t spp = 12;
  // One sampling pass per iteration: the curves then compare the culled meshlets after the same
  // number of occlusion samples per pixel. (This scene's spheres cover several pixels, alpha_s = 1:
  // random acceptance reaches the same final culling, only later; the difference is the speed.)
  RenderRun normal = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, spp, false, 1);
  RenderRun random = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_RANDOM, spp, false, 1);
  // Compare the culled meshlets after the same number of iterations.
  ASSERT_FALSE(normal.stats.cull.culled_per_iteration.empty());
  ASSERT_FALSE(random.stats.cull.culled_per_iteration.empty());
  const size_t n = std::min(normal.stats.cull.culled_per_iteration.size(), random.stats.cull.culled_per_iteration.size());
  double sum_normal = 0, sum_random = 0;  // area under the culling curve: how fast culling grows
  for (size_t i = 0; i < n; ++i) {
    sum_normal += normal.stats.cull.culled_per_iteration[i];
    sum_random += random.stats.cull.culled_per_iteration[i];
  }
  auto curve = [](const RenderRun& r) {
    std::string s;
    for (uint32_t c : r.stats.cull.culled_per_iteration) s += std::to_string(c) + " ";
    return s;
  };
  EXPECT_GE(sum_normal, 1.5 * sum_random) << "normal " << sum_normal << " random " << sum_random << "\nnormal: "
                                          << curve(normal) << "\nrandom: " << curve(random);
}

TEST_F(CullRender, ClassesOnlyMoveUpward) {
  RenderRun r = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, 10, true);
  ASSERT_GE(r.classes.size(), 2u);
  size_t moved = 0;
  for (size_t it = 1; it < r.classes.size(); ++it)
    for (size_t m = 0; m < r.classes[it].size(); ++m) {
      ASSERT_LE(r.classes[it][m], 3u);
      ASSERT_GE(r.classes[it][m], r.classes[it - 1][m]) << "meshlet " << m << " iteration " << it;
      moved += r.classes[it][m] != r.classes[it - 1][m];
    }
  EXPECT_GT(moved, 0u);  // the test observed actual class changes
}

TEST_F(CullRender, ComputeAndRasterizedSamplingAgree) {
  // The occlusion sampling pass rasterized in compute (cull_sample.comp, where the device has
  // 64-bit atomics) and by the rasterizer
  // (cull_sample.vert/.frag) take the same samples: the same pixels (centre in the jittered
  // quad), the same ray test (include/cull_sample.h), the nearest hit per pixel. So every
  // iteration classifies the same meshlets the same way. A pixel centre exactly on a quad edge
  // is the only place the two may differ (the rasterizer's tie rule), hence a small tolerance
  // rather than equality. Two views: the default one (glyphs of a few pixels) and a close-up
  // (glyphs of hundreds of pixels, shared by a subgroup where the device has ballot + shuffle:
  // cull_sample_coop.comp; fails when that loop skips every other pixel).
  if (!ctx_->int64_atomics()) GTEST_SKIP() << "no 64-bit buffer atomics: only the rasterized route exists";
  const uint32_t spp = 10;
  for (double closer : {1.0, 0.3}) {
    SCOPED_TRACE(closer == 1.0 ? "default view" : "close-up");
    RenderRun comp = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, spp, true, 0, 0,
                                  culling::SampleRoute::compute, closer);
    RenderRun rast = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, spp, true, 0, 0,
                                  culling::SampleRoute::raster, closer);
    EXPECT_EQ(comp.stats.cull.sample_passes_compute, comp.stats.cull.samples);
    EXPECT_EQ(rast.stats.cull.sample_passes_raster, rast.stats.cull.samples);
    ASSERT_FALSE(comp.classes.empty());
    ASSERT_EQ(comp.classes.size(), rast.classes.size());
    size_t differ = 0, total = 0;
    for (size_t it = 0; it < comp.classes.size(); ++it)
      for (size_t m = 0; m < comp.classes[it].size(); ++m) {
        differ += comp.classes[it][m] != rast.classes[it][m];
        ++total;
      }
    EXPECT_LE(differ, total / 200) << differ << " of " << total << " (meshlet, iteration) classes differ";
    EXPECT_GT(culled_fraction(comp), 0.2);
    size_t px = 0;
    for (uint32_t y = 0; y < kH; ++y)
      for (uint32_t x = 0; x < kW; ++x) {
        glm::vec4 a = comp.image.at(x, y), b = rast.image.at(x, y);
        if (std::max({std::abs(a.r - b.r), std::abs(a.g - b.g), std::abs(a.b - b.b)}) > 0.1f) ++px;
      }
    EXPECT_LE(px, size_t(kW * kH / 1000));
    std::printf("compute vs rasterized sampling (closer %.1f): %zu of %zu classes differ, %zu pixels, culled %.3f\n",
                closer, differ, total, px, culled_fraction(comp));
  }
}

// The compute route's update over the list of sampled pixels (cull_sample_compact.comp) and the
// update over every pixel apply Algorithm 1 to the same pixels with the same random numbers: the
// same classes in every iteration, and the same image up to exact depth ties. The image is bit
// for bit the same on lavapipe; on an NVIDIA H200 4-5 pixels of the close-up differed (15 of
// 43200 floats) with identical classes: the visibility buffer breaks a tie between two spheres
// by the smaller id, and the ids (sprite record or draw-list slot) are handed out by atomics,
// whose order a GPU does not fix (include/sprite_raster.h).
TEST_F(CullRender, SampledPixelListUpdatesLikeTheFullScreenUpdate) {
  if (!ctx_->int64_atomics()) GTEST_SKIP() << "no 64-bit buffer atomics: no compute sampling route";
  if (!ctx_->compute_ballot()) GTEST_SKIP() << "no subgroup ballots in compute: no sampled-pixel list";
  for (double closer : {1.0, 0.3}) {
    SCOPED_TRACE(closer == 1.0 ? "default view" : "close-up");
    RenderRun list = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, 8, true, 0, 0,
                                  culling::SampleRoute::compute, closer, true, true);
    RenderRun full = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, 8, true, 0, 0,
                                  culling::SampleRoute::compute, closer, true, false);
    ASSERT_FALSE(list.classes.empty());
    EXPECT_EQ(list.classes, full.classes);
    EXPECT_GT(culled_fraction(list), 0.2);
    ASSERT_EQ(list.image.rgba.size(), full.image.rgba.size());
    size_t differ = 0;
    for (uint32_t y = 0; y < kH; ++y)
      for (uint32_t x = 0; x < kW; ++x) differ += list.image.at(x, y) != full.image.at(x, y);
    EXPECT_LE(differ, size_t(kW * kH / 1000)) << "pixels differ (of " << kW * kH << ")";
    if (ctx_->info().type == VK_PHYSICAL_DEVICE_TYPE_CPU) {
      EXPECT_EQ(differ, 0u) << "on " << ctx_->info().name;
    }
  }
}

TEST_F(CullRender, AutomaticSamplingRouteComparesBothRoutes) {
  if (!ctx_->int64_atomics()) GTEST_SKIP() << "no 64-bit buffer atomics: only the rasterized route exists";
  RenderRun r = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, 10);
  ASSERT_GE(r.stats.cull.iterations, 1u);
  ASSERT_GE(r.stats.cull.samples_per_iteration, 2u);
  // The first iteration's passes alternate between the routes (the comparison), then the
  // faster one runs.
  EXPECT_GE(r.stats.cull.sample_passes_compute, r.stats.cull.samples_per_iteration / 2);
  EXPECT_GE(r.stats.cull.sample_passes_raster, r.stats.cull.samples_per_iteration / 2);
  EXPECT_EQ(r.stats.cull.sample_passes_compute + r.stats.cull.sample_passes_raster, r.stats.cull.samples);
}

// RenderSettings::particle_occlusion: after convergence each particle of the potentially visible
// set takes the meshlet rule on its own (particle_occlusion.h). On the dense block most particles
// of the kept meshlets lie behind the front layer: they are hidden, and the image stays that of
// whole meshlets (a hidden particle is behind d_cull with confidence C_occ, as a culled meshlet).
TEST_F(CullRender, ParticleOcclusionHidesParticlesNotPixels) {
  const uint32_t spp = 24;
  for (double closer : {1.0, 0.3}) {
    SCOPED_TRACE(closer == 1.0 ? "default view" : "close-up");
    // The compute path's pre-pass or the task/mesh path's mesh stage runs the test (whichever
    // the device takes: MeshLavapipe.test_cull_render runs this on the mesh path).
    RenderRun on = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, spp, false, 0, 0,
                                culling::SampleRoute::automatic, closer, true);
    RenderRun off = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, spp, false, 0, 0,
                                 culling::SampleRoute::automatic, closer, false);
    EXPECT_EQ(on.stats.mesh_sprites, ctx_->mesh_shaders() && render::prefer_mesh_sprites());
    ASSERT_TRUE(on.stats.cull.converged);
    ASSERT_TRUE(off.stats.cull.converged);
    // The particle test runs after convergence only: the meshlet classes are the same.
    EXPECT_EQ(on.stats.cull.meshlets_culled, off.stats.cull.meshlets_culled);
    EXPECT_EQ(on.stats.cull.particles_listed, off.stats.cull.particles_listed);
    EXPECT_GT(on.stats.cull.particles_listed, 0u);
    EXPECT_EQ(off.stats.cull.particles_occluded, 0u);
    EXPECT_GT(on.stats.cull.particles_occluded, on.stats.cull.particles_listed / 5)
        << on.stats.cull.particles_occluded << " of " << on.stats.cull.particles_listed;
    EXPECT_LT(on.stats.cull.particles_occluded, on.stats.cull.particles_listed);
    // The image holds frames of the potentially visible set (culling converged within spp), so
    // the test shows in it.
    ASSERT_LT(on.stats.cull.iterations_to_converge + 4, spp);
    const size_t differ = mds::testing::differing_pixels(on.image, off.image, 0.1f);
    const size_t faint = mds::testing::differing_pixels(on.image, off.image, 0.01f);
    EXPECT_LE(differ, size_t(kW * kH / 400)) << "hidden " << on.stats.cull.particles_occluded;
    EXPECT_LE(faint, size_t(kW * kH / 100)) << "hidden " << on.stats.cull.particles_occluded;
    std::printf("closer %.1f: converged after %u iterations, %llu of %llu listed particles hidden, %zu / %zu "
                "pixels differ by > 0.1 / 0.01\n",
                closer, on.stats.cull.iterations_to_converge, (unsigned long long)on.stats.cull.particles_occluded,
                (unsigned long long)on.stats.cull.particles_listed, differ, faint);
  }
}

}  // namespace

// The node classes after the first culling iteration of a 1-spp culled render at kW x kH.
static std::vector<uint32_t> first_iteration_classes(vk::Context& ctx, const SceneData& scene, const Camera& cam) {
  auto r = Renderer::create(ctx, scene, culled_settings(1));
  EXPECT_TRUE(r.ok()) << r.error().message;
  if (!r.ok()) return {};
  std::vector<uint32_t> first;
  r.value()->set_iteration_hook([&](uint32_t it) {
    if (it == 0) {
      auto c = r.value()->cull_loop()->node_classes();
      first.assign(c.begin(), c.end());
    }
  });
  EXPECT_TRUE(r.value()->render(cam).ok());
  return first;
}

// RenderSettings::paired_frames: after convergence, every-meshlet and potentially-visible-set
// frames alternately, for a speed-up measured in one process. They add nothing to the image.
TEST_F(CullRender, PairedFramesLeaveTheImageAlone) {
  const uint32_t spp = 24;
  RenderRun plain = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, spp);
  RenderRun paired = render_scene(*ctx_, *scene_, true, MDS_CULL_ACCEPT_NORMAL, spp, false, 0, 3);
  ASSERT_TRUE(paired.stats.cull.converged);
  EXPECT_EQ(plain.stats.cull.paired_frames, 0u);
  EXPECT_EQ(paired.stats.cull.paired_frames, 3u);
  EXPECT_GT(paired.stats.cull.frame_ms_paired_culled, 0.0);
  EXPECT_GT(paired.stats.cull.frame_ms_paired_all, 0.0);
  // Same classes, and the image holds the same spp samples bit for bit.
  EXPECT_EQ(plain.stats.cull.meshlets_culled, paired.stats.cull.meshlets_culled);
  EXPECT_EQ(plain.image.rgba, paired.image.rgba);
}

// A camera inside the block: node boxes that reach behind the near plane take no depth test
// (visible), except those whose part in front of the plane -- the view-space box of their
// corners cut at the near plane -- projects outside the image: they are frustum culled (O), as
// a box entirely in front and outside the image is. The expectation is computed here in double
// from the nodes' boxes and the camera. Before, every box reaching the near plane stayed
// visible, so the nodes beside the eye were drawn (and, streaming, read) in every frame.
TEST_F(CullRender, BoxesBesideTheEyeAreFrustumCulled) {
  Camera cam;
  cam.eye = scene_->bounds.center();
  cam.target = cam.eye + glm::dvec3(0.0, 0.0, -1.0);
  cam.up = {0.0, 1.0, 0.0};
  cam.fov_y_deg = 40.0;
  cam.near = 0.05;
  cam.far = 60.0;
  const std::vector<uint32_t> first = first_iteration_classes(*ctx_, *scene_, cam);
  ASSERT_EQ(first.size(), scene_->nodes.size());

  const glm::dmat4 view = view_matrix(cam, scene_->origin);
  const glm::dmat4 proj = projection_matrix(cam, double(kW) / kH);
  size_t beside = 0, crossing_on_screen = 0;
  for (size_t i = 0; i < scene_->nodes.size(); ++i) {
    const gpu::GpuNode& n = scene_->nodes[i];
    glm::dvec3 lo(1e300), hi(-1e300);
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 p((c & 1) ? n.aabb_max.x : n.aabb_min.x, (c & 2) ? n.aabb_max.y : n.aabb_min.y,
                         (c & 4) ? n.aabb_max.z : n.aabb_min.z);
      const glm::dvec3 v = glm::dvec3(view * glm::dvec4(p, 1.0));
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
    const double znear = -hi.z, zfar = -lo.z;  // view distances
    if (!(znear <= cam.near && zfar > cam.near)) continue;  // not reaching the near plane
    glm::dvec2 a(1e300), b(-1e300);
    for (int c = 0; c < 8; ++c) {
      const glm::dvec4 v((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, -((c & 4) ? zfar : cam.near), 1.0);
      const glm::dvec4 clip = proj * v;
      const glm::dvec2 ndc = glm::dvec2(clip) / clip.w;
      a = glm::min(a, ndc);
      b = glm::max(b, ndc);
    }
    const bool outside = b.x <= -1.0 || b.y <= -1.0 || a.x >= 1.0 || a.y >= 1.0;
    // Boxes whose rectangle edge lies within 1e-3 NDC of the image border are left out (float).
    const bool margin = std::min({std::abs(b.x + 1.0), std::abs(b.y + 1.0), std::abs(a.x - 1.0), std::abs(a.y - 1.0)}) < 1e-3;
    if (margin) continue;
    if (outside) {
      ++beside;
      EXPECT_EQ(first[i], uint32_t(MDS_CULL_CLASS_O)) << "node " << i << " beside the eye";
    } else {
      ++crossing_on_screen;
      EXPECT_NE(first[i], uint32_t(MDS_CULL_CLASS_O)) << "node " << i << " reaches the near plane on screen";
    }
  }
  EXPECT_GT(beside, 0u);
  EXPECT_GT(crossing_on_screen, 0u);
}

// A box whose projected rectangle overlaps the image while the box itself covers no pixel: the
// camera's up vector turned by 45 degrees makes an axis-aligned cluster project as a diamond,
// placed beyond the image's corner so that the diamond's bounding rectangle reaches a few pixels
// into the image. No texel's ray reaches the box, so it is frustum culled (O) in the first
// classification (before, a rectangle without a reached texel counted as P: on the porous 8M
// close-up two far nodes at the image's corner were read for nothing, 1.34x the visible bytes).
TEST_F(CullRender, BoxBeyondTheImageCornerIsFrustumCulled) {
  std::vector<glm::dvec3> pos;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) pos.push_back({0.25 * i, 0.25 * j, -0.25 * k});  // cluster A, on screen
  const size_t a_count = pos.size();
  // Screen axes: right = (1, -1, 0) / sqrt 2, up = (1, 1, 0) / sqrt 2; the image spans
  // +-80 tan(5 deg) = +-7.0 units high and +-9.33 wide at the target's distance. Cluster B (2.4
  // units square: a diamond of half-diagonal 1.70) centred 1.36 units beyond the corner along both
  // screen axes: its rectangle reaches 0.34 units (2 pixels) into the image, its nearest point
  // stays 1.0 unit (6 pixels) outside.
  const double sx = 9.33 + 1.36, sy = 7.0 + 1.36;
  const glm::dvec3 b_centre((sx + sy) / std::sqrt(2.0), (sy - sx) / std::sqrt(2.0), 0.0);
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 9; ++j)
      for (int i = 0; i < 9; ++i) pos.push_back(b_centre + glm::dvec3(0.25 * (i - 4), 0.25 * (j - 4), -0.25 * k));
  std::vector<uint8_t> types(pos.size(), 0);
  const float radius[1] = {0.2f};
  // Nodes of <= 75 particles: A is one node (the partition's first split separates the
  // clusters), B several.
  auto scene = scene_from_particles(pos, types, radius, uint32_t(a_count), 16);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_GE(scene->nodes.size(), 3u);

  Camera cam;
  cam.eye = {0.0, 0.0, 80.0};
  cam.target = {0.0, 0.0, 0.0};
  cam.up = glm::normalize(glm::dvec3(1.0, 1.0, 0.0));
  cam.fov_y_deg = 10.0;
  cam.near = 1.0;
  cam.far = 200.0;
  // The premise, on the CPU: every particle of B lies outside the image by more than its radius
  // and a pixel (no pixel can show it), and some node of B has a box whose rectangle overlaps
  // the image.
  const glm::dmat4 view = view_matrix(cam, scene->origin);
  const glm::dmat4 proj = projection_matrix(cam, double(kW) / kH);
  const double px = 2.0 / kH;  // NDC units per pixel along y (along x, 2 / kW: smaller)
  for (size_t i = a_count; i < pos.size(); ++i) {
    const glm::dvec4 clip = proj * (view * glm::dvec4(pos[i] - scene->origin, 1.0));
    const glm::dvec2 ndc = glm::dvec2(clip) / clip.w;
    EXPECT_GT(std::max(std::abs(ndc.x) - 1.0, std::abs(ndc.y) - 1.0), 3.0 * px) << "particle " << i;
  }
  std::vector<bool> of_b(scene->nodes.size());
  size_t b_overlapping = 0;
  for (size_t k = 0; k < scene->nodes.size(); ++k) {
    const gpu::GpuNode& n = scene->nodes[k];
    of_b[k] = double(n.aabb_min.x) + scene->origin.x > 6.0;  // A lies at x < 1.2, B at x > 12
    glm::dvec2 lo(1e300), hi(-1e300);
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 p((c & 1) ? n.aabb_max.x : n.aabb_min.x, (c & 2) ? n.aabb_max.y : n.aabb_min.y,
                         (c & 4) ? n.aabb_max.z : n.aabb_min.z);
      const glm::dvec4 clip = proj * (view * glm::dvec4(p, 1.0));
      lo = glm::min(lo, glm::dvec2(clip) / clip.w);
      hi = glm::max(hi, glm::dvec2(clip) / clip.w);
    }
    // Overlapping by more than a pixel on both axes (not a float tie at the border).
    if (of_b[k] && lo.x < 1.0 - px && lo.y < 1.0 - px && hi.x > -1.0 + px && hi.y > -1.0 + px) ++b_overlapping;
  }
  ASSERT_EQ(std::count(of_b.begin(), of_b.end(), false), 1) << "A is one node";
  ASSERT_GT(b_overlapping, 0u) << "a node of B whose rectangle reaches into the image";

  const std::vector<uint32_t> first = first_iteration_classes(*ctx_, *scene, cam);
  ASSERT_EQ(first.size(), scene->nodes.size());
  for (size_t k = 0; k < first.size(); ++k)
    EXPECT_EQ(first[k], of_b[k] ? uint32_t(MDS_CULL_CLASS_O) : uint32_t(MDS_CULL_CLASS_P))
        << "node " << k << (of_b[k] ? " of B covers no pixel" : " (A) is on screen");
}

namespace {

// A wall of 24 x 41 x 41 spheres (radius 0.2, spacing 0.25: opaque; thick enough for the
// confidence to pass C_occ behind it) over x, y in [0, 10], z in [-5.75, 0] (node 0), and behind
// it node 1: a cluster at z in [-8, -7.5] behind the wall's centre plus one sphere at
// (35, 5, 39.6), beside the view. Node 1's box (z in [-8.2, 39.8]) reaches far in front of the
// wall, and so does the coarse occupancy cell holding the cluster (a quarter of the box: z up
// to 3.8); only the cluster's sub-cell (z up to -2.2) lies behind the wall's front (z = 0.2).
SceneData wall_and_hidden_node() {
  std::vector<glm::dvec3> pos;
  for (int l = 0; l < 24; ++l)
    for (int j = 0; j <= 40; ++j)
      for (int i = 0; i <= 40; ++i) pos.push_back({0.25 * i, 0.25 * j, -0.25 * l});
  const size_t wall = pos.size();
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) pos.push_back({4.5 + 0.25 * i, 4.5 + 0.25 * j, -8.0 + 0.25 * k});
  pos.push_back({35.0, 5.0, 39.6});
  std::vector<uint8_t> types(pos.size(), 0);
  const float radius[1] = {0.2f};
  auto s = scene_from_particles(pos, types, radius, uint32_t(wall), 16);
  EXPECT_TRUE(s.ok());
  return std::move(s.value());
}

// Node 1's class after a converged culled render looking at the wall along -z.
uint32_t hidden_node_class(vk::Context& ctx, const SceneData& scene) {
  auto r = Renderer::create(ctx, scene, culled_settings(16));
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  if (!r.ok()) return ~0u;
  std::vector<uint32_t> last;
  r.value()->set_iteration_hook([&](uint32_t) {
    auto c = r.value()->cull_loop()->node_classes();
    last.assign(c.begin(), c.end());
  });
  Camera cam;
  cam.eye = {5.0, 5.0, 80.0};
  cam.target = {5.0, 5.0, 0.0};
  cam.up = {0.0, 1.0, 0.0};
  cam.fov_y_deg = 10.0;  // the wall fills about 70 % of the image height
  cam.near = 1.0;
  cam.far = 200.0;
  EXPECT_TRUE(r.value()->render(cam).ok());
  EXPECT_EQ(last.size(), 2u);
  return last.size() == 2 ? last[1] : ~0u;
}

}  // namespace

// The node test refines an occupied cell that lies in front into its occupied sub-cells
// (cull_classify.comp; the fine level of GpuNode::occupancy_fine): the hidden node reaches O with
// its fine level, and stays P with the coarse cells alone or with its whole box.
TEST_F(CullRender, SubCellsLetANodeWhoseCellPokesThroughTheWallReachO) {
  SceneData scene = wall_and_hidden_node();
  ASSERT_EQ(scene.nodes.size(), 2u);
  ASSERT_EQ(scene.nodes[1].particle_count, 76u);
  // The cluster's coarse cell reaches in front of the wall, its sub-cell does not.
  const gpu::GpuNode& n = scene.nodes[1];
  const double zmin = n.aabb_min.z + scene.origin.z, zmax = n.aabb_max.z + scene.origin.z;  // world
  ASSERT_GT(zmax, 39.0);
  ASSERT_GT(zmin + (zmax - zmin) / 4.0, 0.2);  // the cluster's coarse cell (z index 0) tops the wall
  ASSERT_LT(zmin + (zmax - zmin) / 8.0, 0.2);  // its lower sub-cell does not

  EXPECT_EQ(hidden_node_class(*ctx_, scene), uint32_t(MDS_CULL_CLASS_O)) << "fine level";
  SceneData coarse = scene;  // the fine level unknown: an occupied cell in front is P
  for (auto& w : coarse.nodes[1].occupancy_fine) w = glm::uvec4(0u);
  EXPECT_EQ(hidden_node_class(*ctx_, coarse), uint32_t(MDS_CULL_CLASS_P)) << "coarse cells only";
  SceneData box = coarse;  // no occupancy: the box test
  set_occupancy(box.nodes[1], ~0ull);
  EXPECT_EQ(hidden_node_class(*ctx_, box), uint32_t(MDS_CULL_CLASS_P)) << "box";
}
