// Camera paths (render/camera_path.h): the keyframe text format (round trip through a real
// file, errors naming file:line), linear interpolation, and the built-in stress-test paths
// (finite cameras that keep their target inside the view frustum).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "render/camera.h"
#include "render/camera_path.h"

namespace fs = std::filesystem;
using namespace mds;
using namespace mds::render;

namespace {

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("mds_camera_path_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

void expect_near_vec(const glm::dvec3& a, const glm::dvec3& b, double tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

std::string error_of(std::string_view text, std::string_view name = "p.cam") {
  auto r = CameraPath::parse(text, name);
  EXPECT_FALSE(r.ok()) << "parsed: " << text;
  return r.ok() ? std::string() : r.error().message;
}

Bounds test_bounds() {
  Bounds b;
  b.min = {-3.0, 10.0, 100.0};
  b.max = {17.0, 22.0, 160.0};
  b.radius_max = 0.5;
  return b;
}

// Target projected with the renderer's own matrices: in front of the camera, inside NDC.
void expect_target_in_view(Camera c, const Bounds& b, double aspect, uint32_t frame) {
  fit_clip_planes(c, b);
  const glm::dvec3 origin = b.min;
  glm::dvec4 clip = projection_matrix(c, aspect) * view_matrix(c, origin) * glm::dvec4(c.target - origin, 1.0);
  ASSERT_GT(clip.w, 0.0) << "frame " << frame;
  glm::dvec3 ndc = glm::dvec3(clip) / clip.w;
  EXPECT_LE(std::abs(ndc.x), 1.0 + 1e-9) << "frame " << frame;
  EXPECT_LE(std::abs(ndc.y), 1.0 + 1e-9) << "frame " << frame;
}

}  // namespace

TEST(CameraPath, SaveLoadRoundTripIsExact) {
  std::vector<CameraKey> keys(3);
  keys[0].frame = 0;
  keys[0].camera.eye = {0.1, 1.0 / 3.0, 40.0};
  keys[0].camera.target = {10.0, 10.0, 10.0};
  keys[0].camera.up = {0.0, 1.0, 0.0};
  keys[0].camera.fov_y_deg = 40.0;
  keys[1].frame = 17;
  keys[1].camera.eye = {-1e-7, 2.5e8, -3.75};
  keys[1].camera.target = {1.0, 2.0, 3.0};
  keys[1].camera.up = glm::normalize(glm::dvec3(0.2, 0.9, 0.1));
  keys[1].camera.fov_y_deg = 33.3333;
  keys[1].camera.ortho = true;
  keys[2].frame = 120;
  keys[2].camera.eye = {40.0, 10.0, 10.0};
  keys[2].camera.target = {10.0, 10.0, 10.0};
  keys[2].camera.up = {0.0, 0.0, 1.0};
  keys[2].camera.fov_y_deg = 60.0;
  CameraPath path(keys);
  const fs::path file = temp_dir() / "roundtrip.cam";
  ASSERT_TRUE(path.save(file).ok());
  auto loaded = CameraPath::load(file);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  ASSERT_EQ(loaded->keys().size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const CameraKey& a = path.keys()[i];
    const CameraKey& b = loaded->keys()[i];
    EXPECT_EQ(a.frame, b.frame);
    EXPECT_TRUE(identical_cameras(a.camera, b.camera)) << "key " << i;
  }
  EXPECT_EQ(loaded->frame_count(), 121u);
  EXPECT_EQ(loaded->to_text(), path.to_text());
  // No temporary file is left next to the output.
  size_t files = 0;
  for (auto& e : fs::directory_iterator(file.parent_path())) files += e.path().filename().string().rfind("roundtrip", 0) == 0;
  EXPECT_EQ(files, 1u);
  fs::remove_all(file.parent_path());
}

TEST(CameraPath, ParsesCommentsBlankLinesAndPlusSigns) {
  auto r = CameraPath::parse(
      "# mdstream camera path v1\n\n   # indented comment\n0 10 10 40 10 10 10 0 1 0 40 0  # trailing\r\n"
      "\t120 +40 10 10 10 10 10 0 2 0 40 0\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->keys().size(), 2u);
  EXPECT_EQ(r->keys()[1].frame, 120u);
  EXPECT_EQ(r->keys()[1].camera.eye.x, 40.0);
  EXPECT_EQ(r->keys()[1].camera.up, glm::dvec3(0, 2, 0));  // stored as written
  expect_near_vec(r->at(120).up, {0, 1, 0}, 1e-15);          // returned normalised
}

TEST(CameraPath, InterpolatesLinearlyAndHoldsTheEnds) {
  auto r = CameraPath::parse(
      "10 0 0 10 0 0 0 0 1 0 30 0\n"
      "20 10 0 10 10 0 0 1 0 0 50 0\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const CameraPath& p = *r;
  EXPECT_TRUE(identical_cameras(p.at(0), p.keys()[0].camera));   // before the first key: held
  EXPECT_TRUE(identical_cameras(p.at(10), p.keys()[0].camera));
  EXPECT_TRUE(identical_cameras(p.at(20), p.keys()[1].camera));
  EXPECT_TRUE(identical_cameras(p.at(1000), p.keys()[1].camera));  // past the last key: held
  const Camera mid = p.at(15);
  expect_near_vec(mid.eye, {5, 0, 10}, 1e-12);
  expect_near_vec(mid.target, {5, 0, 0}, 1e-12);
  EXPECT_NEAR(mid.fov_y_deg, 40.0, 1e-12);
  expect_near_vec(mid.up, glm::normalize(glm::dvec3(1, 1, 0)), 1e-12);  // renormalised
  const Camera q = p.at(12);
  expect_near_vec(q.eye, {2, 0, 10}, 1e-12);
  EXPECT_NEAR(q.fov_y_deg, 34.0, 1e-12);
  EXPECT_EQ(p.frame_count(), 21u);
}

TEST(CameraPath, EqualKeyframesHoldTheViewExactly) {
  auto r = CameraPath::parse(
      "0 0.1 0.7 13.3 0.3 0.2 0.1 0.1 0.9 0.3 37.7 0\n"
      "9 0.1 0.7 13.3 0.3 0.2 0.1 0.1 0.9 0.3 37.7 0\n"
      "10 5 0.7 13.3 0.3 0.2 0.1 0.1 0.9 0.3 37.7 1\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (uint32_t f = 1; f <= 9; ++f) EXPECT_TRUE(identical_cameras(r->at(f), r->at(0))) << f;
  EXPECT_FALSE(identical_cameras(r->at(10), r->at(9)));
  EXPECT_TRUE(r->at(10).ortho);
  EXPECT_FALSE(r->at(9).ortho);
}

TEST(CameraPath, ErrorsNameFileAndLine) {
  std::string e = error_of("# header\n0 10 10 40 10 10 10 0 1 0 40\n", "bad.cam");
  EXPECT_NE(e.find("bad.cam:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("expected 12 fields"), std::string::npos) << e;
  EXPECT_NE(e.find("found 11"), std::string::npos) << e;

  e = error_of("0 10 10 40 10 10 10 0 1 0 40 0 7\n");
  EXPECT_NE(e.find("p.cam:1:"), std::string::npos) << e;
  EXPECT_NE(e.find("found 13"), std::string::npos) << e;

  e = error_of("0 10 10 40 10 10 10 0 1 0 40 0\n\n5 10 10 40 10 10 10 0 1 0 40 0\n5 10 10 41 10 10 10 0 1 0 40 0\n");
  EXPECT_NE(e.find("p.cam:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("not greater"), std::string::npos) << e;

  e = error_of("9 10 10 40 10 10 10 0 1 0 40 0\n3 10 10 40 10 10 10 0 1 0 40 0\n");
  EXPECT_NE(e.find("p.cam:2:"), std::string::npos) << e;

  e = error_of("0 10 nan 40 10 10 10 0 1 0 40 0\n");
  EXPECT_NE(e.find("p.cam:1:"), std::string::npos) << e;
  EXPECT_NE(e.find("ey"), std::string::npos) << e;
  EXPECT_NE(e.find("not finite"), std::string::npos) << e;

  e = error_of("0 10 10 40 10 10 10 0 1 0 inf 0\n");
  EXPECT_NE(e.find("not finite"), std::string::npos) << e;

  e = error_of("0 10 10 40 10 1o 10 0 1 0 40 0\n");
  EXPECT_NE(e.find("'1o' is not a number"), std::string::npos) << e;

  e = error_of("-1 10 10 40 10 10 10 0 1 0 40 0\n");
  EXPECT_NE(e.find("non-negative integer"), std::string::npos) << e;
  e = error_of("1.5 10 10 40 10 10 10 0 1 0 40 0\n");
  EXPECT_NE(e.find("non-negative integer"), std::string::npos) << e;

  e = error_of("0 10 10 40 10 10 10 0 1 0 180 0\n");
  EXPECT_NE(e.find("fov_y_deg"), std::string::npos) << e;
  e = error_of("0 10 10 40 10 10 10 0 1 0 40 2\n");
  EXPECT_NE(e.find("ortho"), std::string::npos) << e;
  e = error_of("0 10 10 40 10 10 40 0 1 0 40 0\n");  // eye == target
  EXPECT_NE(e.find("coincide"), std::string::npos) << e;
  e = error_of("0 10 10 40 10 10 10 0 0 1 40 0\n");  // up parallel to the view direction
  EXPECT_NE(e.find("parallel"), std::string::npos) << e;

  e = error_of("# only comments\n\n", "empty.cam");
  EXPECT_NE(e.find("empty.cam: no keyframes"), std::string::npos) << e;
}

TEST(CameraPath, LoadErrorsNameTheFile) {
  const fs::path dir = temp_dir();
  auto r = CameraPath::load(dir / "missing.cam");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::io);
  EXPECT_NE(r.error().message.find("missing.cam"), std::string::npos);
  {
    std::ofstream f(dir / "bad.cam");
    f << "0 10 10 40 10 10 10 0 1 0 40 0\n1 10 10 40 10 10 10 0 1 0 40\n";
  }
  r = CameraPath::load(dir / "bad.cam");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find((dir / "bad.cam").string() + ":2:"), std::string::npos) << r.error().message;
  fs::remove_all(dir);
}

TEST(CameraPath, BuiltinPathNames) {
  EXPECT_EQ(*parse_builtin_path("orbit"), BuiltinPath::orbit);
  EXPECT_EQ(*parse_builtin_path("flythrough"), BuiltinPath::flythrough);
  EXPECT_EQ(*parse_builtin_path("jumps"), BuiltinPath::jumps);
  auto r = parse_builtin_path("spiral");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("spiral"), std::string::npos);
  for (auto k : {BuiltinPath::orbit, BuiltinPath::flythrough, BuiltinPath::jumps})
    EXPECT_EQ(*parse_builtin_path(builtin_path_name(k)), k);
}

TEST(CameraPath, BuiltinPathsAreFiniteAndKeepTheTargetInView) {
  const Bounds b = test_bounds();
  const double aspect = 16.0 / 9.0;
  for (auto kind : {BuiltinPath::orbit, BuiltinPath::flythrough, BuiltinPath::jumps}) {
    for (uint32_t frames : {1u, 7u, 80u, 301u}) {
      CameraPath p = builtin_path(kind, b, frames, 40.0, aspect);
      ASSERT_EQ(p.frame_count(), frames) << builtin_path_name(kind);
      for (uint32_t f = 0; f < frames; ++f) {
        Camera c = p.at(f);
        for (int i = 0; i < 3; ++i) {
          ASSERT_TRUE(std::isfinite(c.eye[i]) && std::isfinite(c.target[i]) && std::isfinite(c.up[i]))
              << builtin_path_name(kind) << " frame " << f;
        }
        const glm::dvec3 dir = c.target - c.eye;
        ASSERT_GT(glm::length(dir), 0.0);
        EXPECT_NEAR(glm::length(c.up), 1.0, 1e-12);
        EXPECT_GT(glm::length(glm::cross(glm::normalize(dir), c.up)), 1e-3) << builtin_path_name(kind) << " " << f;
        expect_target_in_view(c, b, aspect, f);
      }
      // Through a file and back, the path is the same.
      auto again = CameraPath::parse(p.to_text());
      ASSERT_TRUE(again.ok()) << again.error().message;
      ASSERT_EQ(again->keys().size(), p.keys().size());
      for (size_t i = 0; i < p.keys().size(); ++i) ASSERT_TRUE(identical_cameras(again->keys()[i].camera, p.keys()[i].camera));
    }
  }
}

TEST(CameraPath, BuiltinPathShapes) {
  const Bounds b = test_bounds();
  const glm::dvec3 c = b.center();
  const double R = b.bounding_radius();
  // orbit: constant distance from the centre, looking at it, back at the start after a full turn.
  CameraPath orbit = builtin_path(BuiltinPath::orbit, b, 64, 40.0, 1.5);
  const double d0 = glm::length(orbit.at(0).eye - c);
  EXPECT_GT(d0, R);  // outside the data
  for (uint32_t f = 0; f < 64; ++f) {
    EXPECT_NEAR(glm::length(orbit.at(f).eye - c), d0, 1e-9 * d0);
    expect_near_vec(orbit.at(f).target, c, 1e-12);
  }
  expect_near_vec(orbit.at(32).eye - c, glm::dvec3(-1, 1, -1) * (orbit.at(0).eye - c), 1e-9 * d0);

  // flythrough: starts and ends outside the bounding sphere, passes (near) the centre at mid-path.
  CameraPath fly = builtin_path(BuiltinPath::flythrough, b, 101, 40.0, 1.5);
  EXPECT_GT(glm::length(fly.at(0).eye - c), R);
  EXPECT_GT(glm::length(fly.at(100).eye - c), R);
  EXPECT_LT(glm::length(fly.at(50).eye - c), 1e-9 * R);
  const glm::dvec3 travel = glm::normalize(fly.at(100).eye - fly.at(0).eye);
  for (uint32_t f = 0; f < 101; f += 10)  // looking ahead
    EXPECT_GT(glm::dot(glm::normalize(fly.at(f).target - fly.at(f).eye), travel), 0.999);

  // jumps: 8 held views, a cut every frames/8 frames, all different.
  CameraPath jumps = builtin_path(BuiltinPath::jumps, b, 80, 40.0, 1.5);
  int cuts = 0;
  for (uint32_t f = 1; f < 80; ++f) {
    const bool cut = !identical_cameras(jumps.at(f), jumps.at(f - 1));
    EXPECT_EQ(cut, f % 10 == 0) << f;
    cuts += cut;
  }
  EXPECT_EQ(cuts, 7);
  const auto views = jump_views(b, 40.0, 1.5);
  ASSERT_EQ(views.size(), 8u);
  for (size_t i = 0; i < views.size(); ++i)
    for (size_t j = i + 1; j < views.size(); ++j) EXPECT_GT(glm::length(views[i].eye - views[j].eye), 1e-6 * R);
}
