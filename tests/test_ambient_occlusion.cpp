// Ambient occlusion of the sphere glyphs (shading/ambient_occlusion.h, SAO): the float mirror of
// shaders/include/ambient_occlusion.glsl against the double reference, including the hard cases
// (a tap at the shaded point, on the radius, in the tangent plane; radii of 1e-6 and 1e6);
// then on the real Vulkan device (lavapipe): the visibility resolve's obscurance of every pixel
// against the CPU reference computed from the frame's own depth buffer, a lone sphere drawn
// exactly as without it, only ever darker, the attachment route without it; and the CLI
// (--ao auto by the store's packing fraction, errors).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "glsl_float_shim.h"
#include "render/camera.h"
#include "render/culling/density_volume.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render_test_helpers.h"
#include "shading/ambient_occlusion.h"

namespace glslf {
using uint = uint32_t;
using std::cos;
using std::sin;
#define MDS_INOUT(T) T&
#include "../shaders/include/ambient_occlusion.glsl"
#undef MDS_INOUT
}  // namespace glslf

using namespace mds;
using namespace mds::shading;
namespace fs = std::filesystem;

namespace {

TEST(AmbientOcclusion, FloatMirrorMatchesDoubleReference) {
  EXPECT_EQ(glslf::MDS_AO_TAPS, kAoTaps);
  EXPECT_EQ(double(glslf::MDS_AO_SPIRAL_TURNS), kAoSpiralTurns);
  EXPECT_EQ(glslf::MDS_AO_BIAS, float(kAoBias));
  EXPECT_EQ(glslf::MDS_AO_EPSILON, float(kAoEpsilon));
  EXPECT_EQ(glslf::MDS_AO_SPIN_STEP, kAoSpinStep);
  EXPECT_EQ(kAoSpinStep, uint32_t(std::lround(0.5 * (std::sqrt(5.0) - 1.0) * 16777216.0)));
  // A pixel's spins over its samples: k golden-ratio turns apart (mod 1), so 16 samples leave no
  // gap wider than 2 / 16 of the circle (three-distance theorem: at most 3 gap lengths).
  {
    std::vector<double> turns;
    for (uint32_t k = 0; k < 16; ++k) turns.push_back(ao_spin(17, 5, k) / 6.283185307179586);
    std::sort(turns.begin(), turns.end());
    double widest = 1.0 - turns.back() + turns.front();
    for (size_t k = 1; k < turns.size(); ++k) widest = std::max(widest, turns[k] - turns[k - 1]);
    EXPECT_LT(widest, 2.0 / 16);
  }
  std::mt19937 rng(7);
  std::uniform_int_distribution<uint32_t> coord(0, 16384);
  std::uniform_real_distribution<double> unit(-1.2, 1.2);
  for (int k = 0; k < 2000; ++k) {
    const uint32_t x = coord(rng), y = coord(rng), s = coord(rng) % 4096;
    ASSERT_EQ(glslf::mds_ao_hash(x, y), ao_hash(x, y));  // the same bits
    EXPECT_NEAR(glslf::mds_ao_spin(x, y, s), ao_spin(x, y, s), 1e-6);
    const double spin = ao_spin(x, y, s);
    for (int i = 0; i < kAoTaps; ++i) {
      float fx = 0, fy = 0;
      double dx = 0, dy = 0;
      glslf::mds_ao_tap_offset(i, kAoTaps, float(spin), 100.0f, fx, fy);
      ao_tap_offset(i, kAoTaps, spin, 100.0, dx, dy);
      EXPECT_NEAR(fx, dx, 1e-3);  // float angles of up to 7 turns: 1e-5 px per px of radius
      EXPECT_NEAR(fy, dy, 1e-3);
      EXPECT_LE(dx * dx + dy * dy, 100.0 * 100.0);
    }
    // A random tap against a random unit normal.
    glm::dvec3 n(unit(rng), unit(rng), unit(rng));
    n = glm::length(n) > 1e-3 ? glm::normalize(n) : glm::dvec3(0, 0, 1);
    const glm::dvec3 u(unit(rng), unit(rng), unit(rng));
    const double want = ao_tap(u.x, u.y, u.z, n.x, n.y, n.z);
    EXPECT_NEAR(glslf::mds_ao_tap(float(u.x), float(u.y), float(u.z), float(n.x), float(n.y), float(n.z)), want,
                1e-5 * std::max(1.0, want));
    EXPECT_GE(want, 0.0);
  }
  // Hard cases. A tap at the shaded point, on the radius or beyond, or in the tangent plane
  // (u.n <= beta) adds nothing; straight along the normal at distance d: (1 - d^2)^3 (d - beta) / (d^2 + eps).
  EXPECT_EQ(ao_tap(0, 0, 0, 0, 0, 1), 0.0);
  EXPECT_EQ(glslf::mds_ao_tap(0, 0, 0, 0, 0, 1), 0.0f);
  EXPECT_EQ(ao_tap(0, 0, 1.0, 0, 0, 1), 0.0);
  EXPECT_EQ(ao_tap(0, 0, 3.0, 0, 0, 1), 0.0);
  EXPECT_EQ(ao_tap(0.5, 0.0, kAoBias, 0, 0, 1), 0.0);
  const double d = 0.5;
  EXPECT_DOUBLE_EQ(ao_tap(0, 0, d, 0, 0, 1), std::pow(1 - d * d, 3) * (d - kAoBias) / (d * d + kAoEpsilon));
  // A depends on the geometry in units of r: the same taps at r = 1e-6 and 1e6 (float too).
  for (const double r : {1e-6, 1.0, 1e6}) {
    const glm::dvec3 C(0.3 * r, -0.2 * r, -5.0 * r), Q = C + glm::dvec3(0.2, 0.1, 0.4) * r;
    const glm::dvec3 u = (Q - C) / r;
    EXPECT_NEAR(ao_tap(u.x, u.y, u.z, 0, 0, 1), ao_tap(0.2, 0.1, 0.4, 0, 0, 1), 1e-12);
    const glm::vec3 uf = (glm::vec3(Q) - glm::vec3(C)) / float(r);
    EXPECT_NEAR(glslf::mds_ao_tap(uf.x, uf.y, uf.z, 0, 0, 1), ao_tap(0.2, 0.1, 0.4, 0, 0, 1), 1e-5);
  }
  // The obscurance: 1 without taps or strength, clamped at 0 for a large sum.
  EXPECT_EQ(ao_obscurance(0.0, kAoTaps, 1.0), 1.0);
  EXPECT_EQ(ao_obscurance(5.0, kAoTaps, 0.0), 1.0);
  EXPECT_EQ(ao_obscurance(1e9, kAoTaps, 1.0), 0.0);
  EXPECT_EQ(glslf::mds_ao_obscurance(1e30f, kAoTaps, 1.0f), 0.0f);
  EXPECT_NEAR(glslf::mds_ao_obscurance(1.2f, kAoTaps, 0.7f), ao_obscurance(1.2, kAoTaps, 0.7), 1e-6);
  // Screen radius: r * |proj y| * H / 2 / depth, orthographic without the depth.
  EXPECT_DOUBLE_EQ(ao_screen_radius(1.5, 2.0, 100.0, 10.0, false), 15.0);
  EXPECT_DOUBLE_EQ(ao_screen_radius(1.5, 2.0, 100.0, 10.0, true), 150.0);
  EXPECT_FLOAT_EQ(glslf::mds_ao_screen_radius(1.5f, 2.0f, 100.0f, 10.0f, false), 15.0f);
}

TEST(AmbientOcclusion, PackingFractionWeighsCellsByTheirParticles) {
  // Two cells of volume 10: 8 particles of volume 0.5 in one (phi 0.4), 2 in the other (0.1).
  const int32_t counts[3] = {8, 2, 0};
  EXPECT_NEAR(packing_fraction(counts, 3, 10.0, 0.5), (8 * 0.4 + 2 * 0.1) / 10.0, 1e-12);
  const int32_t none[2] = {0, 0};
  EXPECT_EQ(packing_fraction(none, 2, 10.0, 0.5), 0.0);
}

// A pyramid of touching spheres: a 3 x 3 layer of radius 0.5 at spacing 1 and one on top in the
// hollow of the middle four, so that contacts and crevices face the camera.
std::vector<glm::dvec3> pyramid() {
  std::vector<glm::dvec3> p;
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 3; ++x) p.push_back({double(x), double(y), 0.0});
  p.push_back({0.5, 0.5, std::sqrt(0.5)});
  return p;
}

class AmbientOcclusionGpu : public mds::testing::VulkanSuite {
 protected:
  static render::SceneData scene(const std::vector<glm::dvec3>& pos) {
    const std::vector<uint8_t> types(pos.size(), 0);
    const float radius[1] = {0.5f};
    auto s = render::scene_from_particles(pos, types, radius, 4096, 16);
    EXPECT_TRUE(s.ok());
    return std::move(s).value();
  }
  static render::Camera camera() {
    render::Camera c;
    c.eye = {4.0, -3.0, 4.5};
    c.target = {1.0, 1.0, 0.2};
    c.up = {0.0, 0.0, 1.0};
    c.fov_y_deg = 40.0;
    c.near = 0.5;
    c.far = 20.0;
    return c;
  }
  // 128 x 96, one sample, the compute sprite path; ambient occlusion of radius 1.5 at this strength.
  static render::RenderSettings settings(double ao_strength, bool visibility_route = true) {
    render::RenderSettings rs;
    rs.width = 128;
    rs.height = 96;
    rs.spp = 1;
    rs.mesh_shaders = render::MeshShaderMode::off;
    rs.visibility_route = visibility_route;
    rs.ao_radius = 1.5;
    rs.ao_strength = ao_strength;
    return rs;
  }
  static Result<mds::testing::RenderedFrame> draw(const render::SceneData& s, double ao_strength,
                                                  bool visibility_route = true) {
    MDS_ASSIGN_OR_RETURN(auto r, render::Renderer::create(*ctx_, s, settings(ao_strength, visibility_route)));
    mds::testing::RenderedFrame out;
    MDS_ASSIGN_OR_RETURN(out.image, r->render(camera(), &out.stats));
    MDS_ASSIGN_OR_RETURN(out.depth, r->read_last_depth());
    return out;
  }
};

// Every covered pixel's obscurance on the GPU (the image with it over the image without, one
// sample) against the CPU reference on the same frame: C unprojected from the pixel's depth, n
// from the sphere C lies on, the taps' points from the depth buffer, the spin of sample 0.
TEST_F(AmbientOcclusionGpu, ResolveMatchesTheCpuReferenceOnItsDepthBuffer) {
  const render::SceneData s = scene(pyramid());
  auto off = draw(s, 0.0), on = draw(s, 1.0);
  ASSERT_TRUE(off.ok()) << off.error().message;
  ASSERT_TRUE(on.ok()) << on.error().message;
  EXPECT_FALSE(off->stats.ambient_occlusion);
  EXPECT_TRUE(on->stats.ambient_occlusion);
  ASSERT_EQ(on->depth, off->depth);  // the same geometry

  const uint32_t W = 128, H = 96;
  const render::Camera cam = camera();
  const glm::dvec2 jitter = render::halton_jitter(0);
  const glm::dmat4 proj = render::projection_matrix(cam, double(W) / H, {2.0 * jitter.x / W, 2.0 * jitter.y / H});
  const glm::dmat4 inv_proj = glm::inverse(proj), view = render::view_matrix(cam, s.origin);
  std::vector<glm::dvec3> centres;  // view space, decoded as the GPU draws them
  for (uint32_t node = 0; node < s.nodes.size(); ++node)
    for (uint32_t i = 0; i < s.nodes[node].particle_count; ++i)
      centres.push_back(glm::dvec3(view * glm::dvec4(glm::dvec3(render::culling::decoded_position(s, node, i)), 1.0)));
  auto point = [&](uint32_t x, uint32_t y, glm::dvec3& p) {
    const float depth = on->depth[size_t(y) * W + x];
    if (!(depth < 1.0f)) return false;
    const glm::dvec4 h = inv_proj * glm::dvec4((x + 0.5) / W * 2.0 - 1.0, (y + 0.5) / H * 2.0 - 1.0, depth, 1.0);
    p = glm::dvec3(h) / h.w;
    return true;
  };
  size_t covered = 0, close = 0, darkened = 0;
  double worst = 0.0;
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x) {
      glm::dvec3 C;
      if (!point(x, y, C)) continue;
      const glm::vec4 a = on->image.at(x, y), b = off->image.at(x, y);
      const float m = std::max({b.x, b.y, b.z});
      if (m < 0.05f) continue;  // too dark to divide
      const double gpu = (m == b.x ? a.x : m == b.y ? a.y : a.z) / m;
      size_t k = 0;
      for (size_t j = 1; j < centres.size(); ++j)
        if (std::abs(glm::length(C - centres[j]) - 0.5) < std::abs(glm::length(C - centres[k]) - 0.5)) k = j;
      const glm::dvec3 n = glm::normalize(C - centres[k]);
      double cpu = 1.0;
      const double rpx = ao_screen_radius(1.5, std::abs(proj[1][1]), H, -C.z, false);
      if (rpx >= 1.0) {
        const double spin = ao_spin(x, y, 0);
        double sum = 0.0;
        for (int i = 0; i < kAoTaps; ++i) {
          double dx = 0, dy = 0;
          ao_tap_offset(i, kAoTaps, spin, rpx, dx, dy);
          const int qx = int(x) + int(std::round(dx)), qy = int(y) + int(std::round(dy));
          glm::dvec3 Q;
          if ((qx == int(x) && qy == int(y)) || qx < 0 || qy < 0 || qx >= int(W) || qy >= int(H) ||
              !point(uint32_t(qx), uint32_t(qy), Q))
            continue;
          const glm::dvec3 u = (Q - C) / 1.5;
          sum += ao_tap(u.x, u.y, u.z, n.x, n.y, n.z);
        }
        cpu = ao_obscurance(sum, kAoTaps, 1.0);
      }
      ++covered;
      close += std::abs(gpu - cpu) <= 2e-3;
      darkened += cpu < 0.9;
      worst = std::max(worst, std::abs(gpu - cpu));
    }
  EXPECT_GT(covered, size_t(W * H) / 8);
  EXPECT_GT(darkened, covered / 10) << "the pyramid's crevices should be darker";
  // Float tap positions round to another pixel where a tap lies within ~1e-3 px of a pixel
  // edge: a handful of pixels.
  EXPECT_GE(close, covered - covered / 100) << "worst " << worst;
}

// No other sphere within the radius: the obscurance is exactly 1 (taps on the sphere itself lie
// behind its tangent plane), and the image is the one without it, bit for bit.
TEST_F(AmbientOcclusionGpu, LoneSphereIsDrawnAsWithout) {
  const render::SceneData s = scene({{1.0, 1.0, 0.3}});
  auto off = draw(s, 0.0), on = draw(s, 1.0);
  ASSERT_TRUE(off.ok() && on.ok());
  EXPECT_TRUE(on->stats.ambient_occlusion);
  EXPECT_EQ(on->image.rgba, off->image.rgba);
}

// Ambient occlusion only darkens; the attachment route (devices without 64-bit atomics) draws
// without it and says so.
TEST_F(AmbientOcclusionGpu, OnlyDarkensAndTheAttachmentRouteHasNone) {
  const render::SceneData s = scene(pyramid());
  auto off = draw(s, 0.0), on = draw(s, 2.0);
  ASSERT_TRUE(off.ok() && on.ok());
  size_t darker = 0;
  for (size_t i = 0; i < on->image.rgba.size(); ++i) {
    ASSERT_LE(on->image.rgba[i], off->image.rgba[i] + 1e-6f) << "pixel " << i / 4;
    darker += on->image.rgba[i] < 0.8f * off->image.rgba[i];
  }
  EXPECT_GT(darker, 100u);
  auto att_off = draw(s, 0.0, false), att_on = draw(s, 1.0, false);
  ASSERT_TRUE(att_off.ok() && att_on.ok());
  EXPECT_FALSE(att_on->stats.visibility_route);
  EXPECT_FALSE(att_on->stats.ambient_occlusion);
  EXPECT_EQ(att_on->image.rgba, att_off->image.rgba);
}

// Switched on in place (the viewer's L key): the next render equals a renderer created with it;
// off again, the one without. Negative values are errors.
TEST_F(AmbientOcclusionGpu, SetInPlaceEqualsCreatedWithIt) {
  const render::SceneData s = scene(pyramid());
  auto off = draw(s, 0.0), on = draw(s, 1.0);
  ASSERT_TRUE(off.ok() && on.ok());
  auto r = render::Renderer::create(*ctx_, s, settings(0.0));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE((*r)->set_ambient_occlusion(1.5, 1.0).ok());
  auto img = (*r)->render(camera());
  ASSERT_TRUE(img.ok());
  EXPECT_TRUE((*r)->stats().ambient_occlusion);
  EXPECT_EQ(img->rgba, on->image.rgba);
  ASSERT_TRUE((*r)->set_ambient_occlusion(1.5, 0.0).ok());
  img = (*r)->render(camera());
  ASSERT_TRUE(img.ok());
  EXPECT_EQ(img->rgba, off->image.rgba);
  EXPECT_FALSE((*r)->set_ambient_occlusion(-1.0, 1.0).ok());
  EXPECT_FALSE((*r)->set_ambient_occlusion(1.0, std::nan("")).ok());
}

// --ao auto by the store's packing fraction: the synthetic gas stays without, the porous block
// gets it; the stats say what was chosen. Bad values are usage errors naming the option.
TEST(AmbientOcclusionCli, AutoFollowsThePackingFractionAndErrorsNameTheOption) {
  const fs::path dir = fs::temp_directory_path() / ("mds_ao_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const std::string scene : {"gas", "porous"}) {
    const std::string dump = (dir / (scene + ".lammpstrj")).string(), store = (dir / (scene + ".mds")).string();
    ASSERT_EQ(mds::testing::run_mdstream("synth --scene " + scene + " --particles 20000 -q -o " + dump), 0);
    ASSERT_EQ(mds::testing::run_mdstream("convert " + dump + " -q -o " + store), 0) << mds::testing::cli_stderr();
    const fs::path json = dir / (scene + ".json");
    ASSERT_EQ(mds::testing::run_mdstream("render " + store + " -o " + (dir / (scene + ".png")).string() +
                                         " --width 64 --height 48 --spp 1 --ao auto --stats " + json.string()),
              0)
        << mds::testing::cli_stderr();
    const nlohmann::json ao = nlohmann::json::parse(std::ifstream(json)).at("ambient_occlusion");
    EXPECT_EQ(ao.at("mode"), "auto");
    const double packing = ao.at("packing_fraction").get<double>();
    EXPECT_EQ(ao.at("on").get<bool>(), scene == "porous") << scene << " packing " << packing;
    if (scene == "gas") EXPECT_LT(packing, kAoAutoPacking);
    else EXPECT_GT(packing, 0.3);
    EXPECT_DOUBLE_EQ(ao.at("radius").get<double>(), 1.5);  // 3 x the default radius 0.5
  }
  const std::string store = (dir / "porous.mds").string(), out = (dir / "x.png").string();
  // Streamed through a GPU cache, the same image: only what the frame shows occludes.
  const std::string look = " --width 96 --height 72 --spp 4 --no-cull --view 2 --ao on -o ";
  ASSERT_EQ(mds::testing::run_mdstream("render " + store + look + (dir / "mem.exr").string()), 0)
      << mds::testing::cli_stderr();
  ASSERT_EQ(mds::testing::run_mdstream("render " + store + " --gpu-budget 4MiB" + look + (dir / "str.exr").string()), 0)
      << mds::testing::cli_stderr();
  const std::vector<float> mem = mds::testing::load_exr(dir / "mem.exr"), str = mds::testing::load_exr(dir / "str.exr");
  ASSERT_EQ(mem.size(), size_t(4 * 96 * 72));
  ASSERT_EQ(str.size(), mem.size());
  size_t differing = 0;
  for (size_t p = 0; p < mem.size(); p += 4)
    differing += std::max({std::abs(mem[p] - str[p]), std::abs(mem[p + 1] - str[p + 1]),
                           std::abs(mem[p + 2] - str[p + 2])}) > 0.1f;
  EXPECT_LE(differing, size_t(96 * 72) / 100);
  EXPECT_EQ(mds::testing::run_mdstream("render " + store + " -o " + out + " --ao maybe"), 2);
  EXPECT_NE(mds::testing::cli_stderr().find("--ao 'maybe'"), std::string::npos) << mds::testing::cli_stderr();
  EXPECT_EQ(mds::testing::run_mdstream("render " + store + " -o " + out + " --ao on --ao-radius -1"), 2);
  EXPECT_NE(mds::testing::cli_stderr().find("--ao-radius"), std::string::npos) << mds::testing::cli_stderr();
  fs::remove_all(dir);
}

}  // namespace
