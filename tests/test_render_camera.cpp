// Camera parsing, default views, projection conventions and the Halton jitter.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "render/camera.h"

using namespace mds;
using namespace mds::render;

TEST(RenderCamera, ParsesEyeTargetAndUp) {
  auto c = parse_camera("1,2,3,4,5,6");
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->eye, glm::dvec3(1, 2, 3));
  EXPECT_EQ(c->target, glm::dvec3(4, 5, 6));
  EXPECT_EQ(c->up, glm::dvec3(0, 1, 0));
  auto d = parse_camera("0,0,5,0,0,0,0,0,1");
  ASSERT_FALSE(d.ok());  // up parallel to the view direction
  auto e = parse_camera("0,0,5,0,0,0,1,0,0");
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e->up, glm::dvec3(1, 0, 0));
}

TEST(RenderCamera, RejectsMalformedSpecs) {
  for (const char* bad : {"", "1,2,3", "1,2,3,4,5,x", "1,2,3,4,5,6,7", "1,1,1,1,1,1", "1,2,3,4,5,nan"}) {
    auto c = parse_camera(bad);
    ASSERT_FALSE(c.ok()) << bad;
    EXPECT_EQ(c.error().code, Errc::invalid_argument);
  }
}

TEST(RenderCamera, PerspectiveMapsNearFarAndFov) {
  Camera c;
  c.eye = {0, 0, 0};
  c.target = {0, 0, -1};
  c.near = 2.0;
  c.far = 50.0;
  c.fov_y_deg = 60.0;
  glm::dmat4 p = projection_matrix(c, 2.0);
  auto ndc = [&](glm::dvec3 v) {
    glm::dvec4 q = p * glm::dvec4(v, 1.0);
    return glm::dvec3(q) / q.w;
  };
  EXPECT_NEAR(ndc({0, 0, -2}).z, 0.0, 1e-12);
  EXPECT_NEAR(ndc({0, 0, -50}).z, 1.0, 1e-12);
  const double t = std::tan(M_PI / 6.0);
  EXPECT_NEAR(ndc({0, 10 * t, -10}).y, -1.0, 1e-12);  // top edge: y up -> NDC -1 (Vulkan)
  EXPECT_NEAR(ndc({20 * t, 0, -10}).x, 1.0, 1e-12);   // aspect 2
  // Jitter shifts every projected point by the same NDC offset.
  glm::dmat4 pj = projection_matrix(c, 2.0, {0.01, -0.02});
  glm::dvec4 q = pj * glm::dvec4(3, -1, -7, 1);
  glm::dvec3 a = glm::dvec3(q) / q.w, b = ndc({3, -1, -7});
  EXPECT_NEAR(a.x - b.x, 0.01, 1e-12);
  EXPECT_NEAR(a.y - b.y, -0.02, 1e-12);
  EXPECT_NEAR(a.z, b.z, 1e-12);
}

TEST(RenderCamera, OrthographicMapsNearFar) {
  Camera c;
  c.eye = {0, 0, 0};
  c.target = {0, 0, -1};
  c.ortho = true;
  c.ortho_half_height = 4.0;
  c.near = 1.0;
  c.far = 11.0;
  glm::dmat4 p = projection_matrix(c, 1.5);
  glm::dvec4 q = p * glm::dvec4(6.0, 4.0, -6.0, 1.0);
  EXPECT_NEAR(q.x / q.w, 1.0, 1e-12);
  EXPECT_NEAR(q.y / q.w, -1.0, 1e-12);
  EXPECT_NEAR(q.z / q.w, 0.5, 1e-12);
}

TEST(RenderCamera, DefaultViewsSeeTheBounds) {
  Bounds b;
  b.min = {-10, 0, 5};
  b.max = {30, 20, 15};
  b.radius_max = 0.5;
  for (int v = 0; v < 3; ++v) {
    auto c = default_view(v, b, 40.0, 16.0 / 9.0);
    ASSERT_TRUE(c.ok());
    fit_clip_planes(*c, b);
    EXPECT_GT(c->near, 0.0);
    EXPECT_GT(c->far, c->near);
    // The target is in front of the camera and inside the bounds.
    EXPECT_GT(glm::dot(c->target - c->eye, c->target - c->eye), 0.0);
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(c->target[a], b.min[a]);
      EXPECT_LE(c->target[a], b.max[a]);
    }
    if (v < 2) {  // every corner of the bounds (grown by the radius) projects inside the image
      for (bool ortho : {false, true}) {
        Camera cc = *c;
        cc.ortho = ortho;
        glm::dmat4 m = projection_matrix(cc, 16.0 / 9.0) * view_matrix(cc, glm::dvec3(0.0));
        for (int i = 0; i < 8; ++i) {
          glm::dvec3 p((i & 1) ? b.max.x + 0.5 : b.min.x - 0.5, (i & 2) ? b.max.y + 0.5 : b.min.y - 0.5,
                       (i & 4) ? b.max.z + 0.5 : b.min.z - 0.5);
          glm::dvec4 q = m * glm::dvec4(p, 1.0);
          EXPECT_LE(std::abs(q.x / q.w), 1.0) << "view " << v << " corner " << i << " ortho " << ortho;
          EXPECT_LE(std::abs(q.y / q.w), 1.0) << "view " << v << " corner " << i << " ortho " << ortho;
          EXPECT_GE(q.z / q.w, 0.0);
          EXPECT_LE(q.z / q.w, 1.0);
        }
      }
    }
  }
  EXPECT_FALSE(default_view(3, b, 40.0, 1.0).ok());
}

TEST(RenderCamera, HaltonJitterIsInsideThePixelAndDistinct) {
  EXPECT_EQ(halton_jitter(0), glm::dvec2(0.0));
  std::set<std::pair<double, double>> seen;
  for (uint32_t s = 0; s < 256; ++s) {
    glm::dvec2 j = halton_jitter(s);
    EXPECT_GE(j.x, -0.5);
    EXPECT_LT(j.x, 0.5);
    EXPECT_GE(j.y, -0.5);
    EXPECT_LT(j.y, 0.5);
    seen.insert({j.x, j.y});
  }
  EXPECT_EQ(seen.size(), 256u);
  EXPECT_DOUBLE_EQ(radical_inverse(6, 2), 0.375);  // 110b -> 0.011b
}
