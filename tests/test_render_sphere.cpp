// Sphere glyph renderer on the real Vulkan device (lavapipe here). Expected images are computed
// in this test independently of the renderer: one ray per pixel centre from the camera's own
// basis (eye, target, up, fov / ortho half height) intersected with the sphere in double.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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

struct Sphere {
  glm::dvec3 c;
  double r;
};

struct Ray {
  glm::dvec3 o, d;
};

// Reference camera: independent of render/camera.cpp.
struct RefCamera {
  glm::dvec3 eye, f, right, up;
  double tan_half = 0, half_h = 0, aspect = 1, near = 1, far = 100;
  bool ortho = false;
  uint32_t w = 0, h = 0;

  RefCamera(const Camera& c, uint32_t width, uint32_t height) : w(width), h(height) {
    eye = c.eye;
    f = glm::normalize(c.target - c.eye);
    right = glm::normalize(glm::cross(f, c.up));
    up = glm::cross(right, f);
    tan_half = std::tan(c.fov_y_deg * M_PI / 360.0);
    half_h = c.ortho_half_height;
    aspect = double(w) / h;
    near = c.near;
    far = c.far;
    ortho = c.ortho;
  }
  Ray ray(double px, double py) const {  // px, py: pixel coordinates of the sample (centre = +0.5)
    double sx = px / w * 2.0 - 1.0, sy = py / h * 2.0 - 1.0;  // sy grows downwards
    if (ortho) return {eye + right * (sx * half_h * aspect) - up * (sy * half_h), f};
    return {eye, glm::normalize(f + right * (sx * tan_half * aspect) - up * (sy * tan_half))};
  }
  double ndc_depth(const glm::dvec3& p) const {
    double z = glm::dot(p - eye, f);
    return ortho ? (z - near) / (far - near) : far / (far - near) * (1.0 - near / z);
  }
};

// Distance of the sphere centre from the ray line, and the front hit (t < 0: miss).
double closest(const Ray& ray, const Sphere& s) {
  glm::dvec3 oc = s.c - ray.o;
  return glm::length(oc - glm::dot(oc, ray.d) * ray.d);
}
double hit_t(const Ray& ray, const Sphere& s) {
  glm::dvec3 oc = ray.o - s.c;
  double b = glm::dot(oc, ray.d);
  glm::dvec3 fv = oc - b * ray.d;
  double disc = s.r * s.r - glm::dot(fv, fv);
  if (disc < 0) return -1.0;
  return -b - std::sqrt(disc);
}

class RenderSphere : public mds::testing::VulkanSuite {
 protected:
  static SceneData scene_of(const std::vector<Sphere>& spheres) {
    std::vector<glm::dvec3> pos;
    std::vector<uint8_t> types;
    std::vector<float> radii;
    for (size_t i = 0; i < spheres.size(); ++i) {
      pos.push_back(spheres[i].c);
      types.push_back(uint8_t(i));
      radii.push_back(float(spheres[i].r));
    }
    auto s = scene_from_particles(pos, types, radii);
    EXPECT_TRUE(s.ok());
    return std::move(s).value();
  }

  using Output = mds::testing::RenderedFrame;
  static Output render(const SceneData& scene, const Camera& cam, uint32_t w, uint32_t h, uint32_t spp) {
    RenderSettings rs;
    rs.width = w;
    rs.height = h;
    rs.spp = spp;
    auto r = Renderer::create(*ctx_, scene, rs);
    EXPECT_TRUE(r.ok()) << r.error().message;
    Output out;
    auto img = (*r)->render(cam, &out.stats);
    EXPECT_TRUE(img.ok()) << img.error().message;
    out.image = std::move(img).value();
    auto d = (*r)->read_last_depth();
    EXPECT_TRUE(d.ok());
    out.depth = std::move(d).value();
    return out;
  }

  // Every pixel: covered (alpha) and depth match the reference, except pixels whose ray passes
  // within 1e-3 r of the silhouette. Returns the number of covered pixels.
  static size_t check_against_reference(const Output& out, const std::vector<Sphere>& spheres, const Camera& cam) {
    RefCamera ref(cam, out.image.width, out.image.height);
    size_t covered = 0, checked_depth = 0;
    for (uint32_t y = 0; y < ref.h; ++y) {
      for (uint32_t x = 0; x < ref.w; ++x) {
        Ray ray = ref.ray(x + 0.5, y + 0.5);
        bool boundary = false;
        double best_t = -1;
        for (const auto& s : spheres) {
          if (std::abs(closest(ray, s) - s.r) < 1e-3 * s.r) boundary = true;
          double t = hit_t(ray, s);
          if (t >= 0 && (best_t < 0 || t < best_t)) best_t = t;
        }
        const float alpha = out.image.at(x, y).a;
        if (alpha > 0.5f) ++covered;
        if (boundary) continue;
        EXPECT_EQ(alpha > 0.5f, best_t >= 0) << "pixel " << x << "," << y;
        if (best_t >= 0) {
          double expect = ref.ndc_depth(ray.o + best_t * ray.d);
          EXPECT_NEAR(out.depth[size_t(y) * ref.w + x], expect, 2e-5) << "pixel " << x << "," << y;
          ++checked_depth;
        } else {
          EXPECT_EQ(out.depth[size_t(y) * ref.w + x], 1.0f);
        }
      }
    }
    EXPECT_GT(checked_depth, 0u);
    return covered;
  }

};

Camera perspective_camera() {
  Camera c;
  c.eye = {0.0, 0.0, 10.0};
  c.target = {0.0, 0.0, 0.0};
  c.up = {0.0, 1.0, 0.0};
  c.fov_y_deg = 40.0;
  c.near = 1.0;
  c.far = 30.0;
  return c;
}

}  // namespace

TEST_F(RenderSphere, PerspectiveDiscAtProjectedCentreWithProjectedRadius) {
  const std::vector<Sphere> spheres = {{{0.0, 0.0, 0.0}, 1.0}};
  const Camera cam = perspective_camera();
  const uint32_t W = 128, H = 128;
  auto out = render(scene_of(spheres), cam, W, H, 1);
  size_t covered = check_against_reference(out, spheres, cam);
  // Projected radius of a sphere on the axis: tan(asin(r/d)) / tan(fov/2) * H/2 pixels.
  const double rho = std::tan(std::asin(1.0 / 10.0)) / std::tan(20.0 * M_PI / 180.0) * H / 2;
  EXPECT_NEAR(double(covered), M_PI * rho * rho, 2.0 * M_PI * rho);
  double sx = 0, sy = 0;
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x)
      if (out.image.at(x, y).a > 0.5f) {
        sx += x + 0.5;
        sy += y + 0.5;
      }
  EXPECT_NEAR(sx / covered, W / 2.0, 0.5);
  EXPECT_NEAR(sy / covered, H / 2.0, 0.5);
  // Centre depth: the front of the sphere at distance d - r on the axis.
  const double z = 10.0 - 1.0;
  const double expect = 30.0 / 29.0 * (1.0 - 1.0 / z);
  const float centre = 0.25f * (out.depth[(H / 2) * W + W / 2] + out.depth[(H / 2 - 1) * W + W / 2] +
                                out.depth[(H / 2) * W + W / 2 - 1] + out.depth[(H / 2 - 1) * W + W / 2 - 1]);
  EXPECT_NEAR(centre, expect, 1e-4);
  EXPECT_EQ(out.stats.particles, 1u);
  EXPECT_EQ(out.stats.meshlets, 1u);
}

TEST_F(RenderSphere, PerspectiveOffAxisSphereMatchesPerPixelRays) {
  // Off-axis spheres project to ellipses; the billboard must still enclose them.
  const std::vector<Sphere> spheres = {{{2.2, 1.3, -1.0}, 0.8}, {{-2.5, -0.7, 2.0}, 0.5}};
  Camera cam = perspective_camera();
  cam.fov_y_deg = 50.0;
  auto out = render(scene_of(spheres), cam, 160, 96, 1);
  EXPECT_GT(check_against_reference(out, spheres, cam), 100u);
}

TEST_F(RenderSphere, OrthographicOffCentreDisc) {
  const std::vector<Sphere> spheres = {{{1.5, 2.3, 3.0}, 0.5}};
  Camera cam;
  cam.eye = {1.0, 2.0, 13.0};
  cam.target = {1.0, 2.0, 3.0};
  cam.ortho = true;
  cam.ortho_half_height = 2.0;
  cam.near = 1.0;
  cam.far = 30.0;
  const uint32_t W = 128, H = 96;
  auto out = render(scene_of(spheres), cam, W, H, 1);
  size_t covered = check_against_reference(out, spheres, cam);
  const double px = H / (2.0 * 2.0);  // pixels per world unit
  const double rho = 0.5 * px;
  EXPECT_NEAR(double(covered), M_PI * rho * rho, 2.0 * M_PI * rho);
  double sx = 0, sy = 0;
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x)
      if (out.image.at(x, y).a > 0.5f) {
        sx += x + 0.5;
        sy += y + 0.5;
      }
  EXPECT_NEAR(sx / covered, W / 2.0 + 0.5 * px, 0.5);  // +x to the right
  EXPECT_NEAR(sy / covered, H / 2.0 - 0.3 * px, 0.5);  // +y up = smaller row
}

TEST_F(RenderSphere, NearerOfTwoOverlappingSpheresWins) {
  Camera cam = perspective_camera();
  for (int order = 0; order < 2; ++order) {
    std::vector<Sphere> spheres = {{{0.0, 0.0, 0.0}, 1.0}, {{0.9, 0.2, 2.0}, 1.0}};  // [1] is nearer
    if (order) std::swap(spheres[0], spheres[1]);
    const size_t nearer = order ? 0 : 1;
    auto scene = scene_of(spheres);
    auto out = render(scene, cam, 128, 128, 1);
    check_against_reference(out, spheres, cam);
    // Pixels where both spheres are hit show the nearer sphere's type colour (hue).
    RefCamera ref(cam, 128, 128);
    const glm::vec3 cn = glm::vec3(scene.types[nearer].color);
    const glm::vec3 cf = glm::vec3(scene.types[1 - nearer].color);
    size_t both = 0;
    for (uint32_t y = 0; y < 128; ++y)
      for (uint32_t x = 0; x < 128; ++x) {
        Ray ray = ref.ray(x + 0.5, y + 0.5);
        if (hit_t(ray, spheres[0]) < 0 || hit_t(ray, spheres[1]) < 0) continue;
        if (closest(ray, spheres[nearer]) > 0.9 * spheres[nearer].r) continue;  // away from silhouettes
        ++both;
        glm::vec3 c = glm::vec3(out.image.at(x, y));
        // Compare chromaticity: angle to the nearer type's colour is the smaller one.
        float dn = glm::dot(glm::normalize(c), glm::normalize(cn));
        float df = glm::dot(glm::normalize(c), glm::normalize(cf));
        EXPECT_GT(dn, df) << "pixel " << x << "," << y << " order " << order;
      }
    EXPECT_GT(both, 50u);
  }
}

TEST_F(RenderSphere, SubPixelSphereContributesItsCoverage) {
  // Projected radius ~0.26 px: area ~0.21 of a pixel. It must not vanish, and over 64 jittered
  // passes the accumulated coverage estimates that area.
  const std::vector<Sphere> spheres = {{{0.0, 0.0, 0.0}, 0.03}};
  const Camera cam = perspective_camera();
  const uint32_t W = 64, H = 64;
  auto out = render(scene_of(spheres), cam, W, H, 64);
  const double rho = std::tan(std::asin(0.03 / 10.0)) / std::tan(20.0 * M_PI / 180.0) * H / 2;
  const double area = M_PI * rho * rho;
  double coverage = 0, colour = 0;
  const glm::vec4 bg = out.image.at(0, 0);
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x) {
      glm::vec4 p = out.image.at(x, y);
      coverage += p.a;
      colour += std::abs(p.r - bg.r) + std::abs(p.g - bg.g) + std::abs(p.b - bg.b);
    }
  EXPECT_GT(coverage, 0.5 * area);
  EXPECT_LT(coverage, 1.5 * area);
  EXPECT_GT(colour, 0.0);
  EXPECT_EQ(bg.a, 0.0f);
}

TEST_F(RenderSphere, SuperSamplingConverges) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::vector<glm::dvec3> pos;
  std::vector<uint8_t> types;
  for (int i = 0; i < 3000; ++i) {
    pos.push_back({u(rng), u(rng), u(rng)});
    types.push_back(uint8_t(i % 4));
  }
  const std::vector<float> radii = {0.05f, 0.08f, 0.12f, 0.03f};
  auto scene = scene_from_particles(pos, types, radii, 1000, 64);
  ASSERT_TRUE(scene.ok());
  Camera cam = perspective_camera();
  cam.near = 0.0;  // fitted to the bounds
  cam.far = 0.0;
  auto a1 = render(*scene, cam, 96, 96, 1);
  auto a16 = render(*scene, cam, 96, 96, 16);
  auto a64 = render(*scene, cam, 96, 96, 64);
  auto diff = [](const FrameImage& a, const FrameImage& b) {
    double s = 0;
    for (size_t i = 0; i < a.rgba.size(); ++i)
      if (i % 4 != 3) s += std::abs(a.rgba[i] - b.rgba[i]);
    return s / (a.rgba.size() * 0.75);
  };
  const double d1 = diff(a1.image, a64.image), d16 = diff(a16.image, a64.image);
  EXPECT_LT(d16, 0.5 * d1);
  EXPECT_LT(d16, 0.01);
  EXPECT_EQ(a64.stats.spp, 64u);
  EXPECT_EQ(a64.stats.particles, 3000u);
  EXPECT_EQ(a64.stats.meshlets, 3u * 16u);  // nodes of 1000 -> 15 x 64 + 40 each
  EXPECT_EQ(a64.stats.pass_ms_median.count("draw"), 1u);
}

// Spheres that cross the near plane beside the eye (a camera inside the data) have nothing on
// screen: the pre-pass must hide them (their part in front of the near plane projects outside
// the image), not cover the viewport with their rectangle -- which costs a ray test per pixel
// each and made frames inside the porous block take seconds on lavapipe. A sphere crossing the
// near plane in front of the eye keeps its rectangle; spheres behind the eye are hidden. The
// sprites beside the eye add no pixel to the image (up to silhouette pixels of the requantized scene).
TEST_F(RenderSphere, SpheresBesideTheEyeStayOffScreen) {
  Camera cam;
  cam.eye = {0.0, 0.0, 0.0};
  cam.target = {0.0, 0.0, -1.0};
  cam.up = {0.0, 1.0, 0.0};
  cam.fov_y_deg = 40.0;
  cam.near = 0.05;
  cam.far = 30.0;
  std::vector<Sphere> seen;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) seen.push_back({{1.2 * x, 1.2 * y, -6.0}, 0.3});  // in front, on screen
  // Crosses the near plane (view distances -0.1 .. 0.3) without holding the eye, its part in
  // front of the plane on screen.
  seen.push_back({{0.25, 0.0, -0.1}, 0.2});
  seen.push_back({{0.0, 0.0, 2.0}, 0.3});  // behind the eye
  std::vector<Sphere> all = seen;
  // Beside the eye: view distances -0.3 .. 0.3 around 0, laterally 2-3 units away.
  for (const glm::dvec3 c : {glm::dvec3(2, 0, 0), glm::dvec3(-2, 0, 0), glm::dvec3(0, 2, 0), glm::dvec3(0, -2, 0),
                             glm::dvec3(3, 3, 0.1), glm::dvec3(-3, 3, -0.1), glm::dvec3(3, -3, 0.1),
                             glm::dvec3(-3, -3, -0.1)})
    all.push_back({c, 0.3});
  const uint32_t W = 64, H = 48;
  auto with = render(scene_of(all), cam, W, H, 1);
  auto without = render(scene_of(seen), cam, W, H, 1);
  if (!with.stats.mesh_sprites) {  // the pre-pass's counts (the task/mesh path has no pre-pass)
    EXPECT_EQ(with.stats.sprites_listed, all.size());
    EXPECT_EQ(with.stats.sprites_offscreen, 1u + (all.size() - seen.size()));  // behind + beside the eye
    EXPECT_EQ(without.stats.sprites_offscreen, 1u);
  }
  // The two scenes quantize their nodes in different frames: a silhouette pixel may flip.
  EXPECT_LE(mds::testing::differing_pixels(with.image, without.image), 2u);
  EXPECT_GT(std::count_if(with.depth.begin(), with.depth.end(), [](float d) { return d < 1.0f; }), 0);
}
