// Colour by coordinate (render/colormap.h, shaders/include/particle_color.h): every colormap's
// table against matplotlib, the view-space plane against the world coordinate, the options'
// parsing, and rendered images against the CPU originals -- a colormap coordinate held at one
// value everywhere must give the image of every type coloured that value's colour of the map.
#include <gtest/gtest.h>
#include <tinyexr.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "render/camera.h"
#include "render/colormap.h"

namespace fs = std::filesystem;
using namespace mds;
using mds::testing::cli_stderr;
using mds::testing::load_exr;
using mds::testing::run_mdstream;

namespace {

// Matplotlib's map `name` at the centres (i + 0.5) / n of n entries (Debian's
// python3-matplotlib), empty when python or matplotlib cannot run.
std::vector<glm::dvec3> matplotlib_map(const std::string& name, int n) {
  const std::string cmd = std::string(MDSTREAM_PYTHON) + " -c \"import matplotlib; m = matplotlib.colormaps['" + name +
                          "']; [print(*m((i + 0.5) / " + std::to_string(n) + ")[:3]) for i in range(" +
                          std::to_string(n) + ")]\" 2>/dev/null";
  std::vector<glm::dvec3> out;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return out;
  double r = 0, g = 0, b = 0;
  while (std::fscanf(p, "%lf %lf %lf", &r, &g, &b) == 3) out.emplace_back(r, g, b);
  ::pclose(p);
  return out;
}

}  // namespace

// Each map's 65 samples, interpolated, at the centres of matplotlib's 256 entries (between the
// samples): 0.002 (gray) to 0.014 (turbo) with matplotlib 3.6.3. Names parse and print back.
TEST(ColorMap, EveryMapIsCloseToMatplotlib) {
  const int n = 256;
  for (int k = 0; k <= int(render::Colormap::gray); ++k) {
    const auto map = render::Colormap(k);
    const std::string name = render::colormap_name(map);
    SCOPED_TRACE(name);
    ASSERT_EQ(*render::parse_colormap(name), map);
    const std::vector<glm::dvec3> ref = matplotlib_map(name, n);
    ASSERT_EQ(ref.size(), size_t(n)) << "python3 with matplotlib (tools/bootstrap.sh installs it)";
    double worst = 0.0;
    for (int i = 0; i < n; ++i) {
      const glm::dvec3 d = glm::abs(render::colormap_srgb(map, (i + 0.5) / n) - ref[size_t(i)]);
      worst = std::max({worst, d.x, d.y, d.z});
    }
    EXPECT_LT(worst, 0.015);
  }
  const auto bad = render::parse_colormap("jet");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("coolwarm"), std::string::npos) << bad.error().message;
  // Dark violet to yellow, clamped beyond the ends.
  const glm::dvec3 lo = render::viridis_srgb(0.0), hi = render::viridis_srgb(1.0);
  EXPECT_GT(lo.b, lo.r);
  EXPECT_GT(lo.r, lo.g);
  EXPECT_GT(hi.r + hi.g, 1.8);
  EXPECT_LT(hi.b, 0.2);
  EXPECT_EQ(render::viridis_srgb(-3.0), lo);
  EXPECT_EQ(render::viridis_srgb(7.0), hi);
}

// t = dot(plane.xyz, p_view) + plane.w is (p_world[axis] - lo) / (hi - lo) for any camera.
TEST(ColorMap, PlaneGivesTheWorldCoordinate) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-50.0, 50.0);
  for (int trial = 0; trial < 20; ++trial) {
    render::Camera cam;
    cam.eye = {u(rng), u(rng), u(rng)};
    cam.target = {u(rng), u(rng), u(rng)};
    cam.up = glm::normalize(glm::dvec3(u(rng), u(rng), u(rng)));
    const glm::dvec3 origin(u(rng), u(rng), u(rng));
    const glm::dmat4 view = render::view_matrix(cam, origin);
    for (int axis = 0; axis < 3; ++axis) {
      const double lo = u(rng), hi = lo + 1.0 + std::abs(u(rng));
      const glm::dvec4 plane = render::color_plane(view, origin, axis, lo, hi);
      for (int k = 0; k < 5; ++k) {
        const glm::dvec3 p(u(rng), u(rng), u(rng));
        const glm::dvec3 pv = glm::dvec3(view * glm::dvec4(p - origin, 1.0));
        EXPECT_NEAR(glm::dot(glm::dvec3(plane), pv) + plane.w, (p[axis] - lo) / (hi - lo), 1e-9);
      }
    }
  }
}

TEST(ColorMap, ParsesAxisAndRange) {
  EXPECT_EQ(*render::parse_color_axis("type"), -1);
  EXPECT_EQ(*render::parse_color_axis("z"), 2);
  EXPECT_FALSE(render::parse_color_axis("Z").ok());
  EXPECT_FALSE(render::parse_color_axis("velocity").ok());
  const auto r = render::parse_color_range("-1.5:2e1");
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->x, -1.5);
  EXPECT_EQ(r->y, 20.0);
  for (const char* bad : {"1", "1:", ":2", "2:1", "1:1", "a:b", "1:2:3", "nan:1", "1:inf"})
    EXPECT_FALSE(render::parse_color_range(bad).ok()) << bad;
  EXPECT_EQ(render::color_axis_name(1), "y");
}

class ColorMapRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mds_colormap_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    const fs::path dump = dir_ / "porous.lammpstrj";
    store_ = (dir_ / "porous.mds").string();
    ASSERT_EQ(run_mdstream("synth --scene porous --particles 20000 -q -o " + dump.string()), 0) << cli_stderr();
    ASSERT_EQ(run_mdstream("convert " + dump.string() + " --node-size 2000 -q -o " + store_), 0) << cli_stderr();
    // The x extent of the particle centres, from a render's stats (the default --color-range).
    const fs::path stats = dir_ / "x.json";
    ASSERT_EQ(run_mdstream("render " + store_ + " --color-by x --width 16 --height 12 --spp 1 --no-cull -o " +
                           (dir_ / "x.png").string() + " --stats " + stats.string()),
              0)
        << cli_stderr();
    std::ifstream f(stats);
    const nlohmann::json j = nlohmann::json::parse(f);
    ASSERT_EQ(j["color_by"]["axis"], "x");
    x_lo_ = j["color_by"]["range"][0].get<double>();
    x_hi_ = j["color_by"]["range"][1].get<double>();
    ASSERT_LT(x_lo_, x_hi_);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::vector<float> render(const std::string& name, const std::string& args) {
    const fs::path exr = dir_ / (name + ".exr");
    EXPECT_EQ(run_mdstream("render " + store_ + " --width 96 --height 72 --spp 4 --no-cull -o " + exr.string() + " " +
                           args),
              0)
        << args << ": " << cli_stderr();
    return load_exr(exr);
  }
  // --type-color for both types of the porous scene (input ids 1 and 2): map's colour at t.
  static std::string map_types(render::Colormap map, double t) {
    const glm::dvec3 c = render::colormap_srgb(map, t);
    const std::string rgb = fmt::format("{:.9f},{:.9f},{:.9f}", c.r, c.g, c.b);
    return "--type-color 1=" + rgb + " --type-color 2=" + rgb;
  }

  static inline fs::path dir_;
  static inline std::string store_;
  static inline double x_lo_ = 0.0, x_hi_ = 0.0;
};

// A range that puts every particle at the same t (far beyond the data: clamped to 0 or 1; or
// so wide that the data spans 2e-5 of it around t) gives the image of every type coloured
// the map's colour at t on the CPU: the shader's interpolation of the frame's samples and its
// sRGB conversion are the CPU's, in memory and streamed, for viridis (the default) and coolwarm
// (between two samples and at the ends). Fails with the plane's sign or offset wrong (the
// clamped ends swap), or the samples or their interpolation changed on one side.
TEST_F(ColorMapRender, ACoordinateHeldAtOneValueColoursLikeThatTypeColour) {
  const double c = 0.5 * (x_lo_ + x_hi_), wide = 1e6;
  const std::pair<render::Colormap, double> cases[] = {
      {render::Colormap::viridis, 0.0}, {render::Colormap::viridis, 0.25}, {render::Colormap::viridis, 0.5},
      {render::Colormap::viridis, 0.8}, {render::Colormap::viridis, 1.0}, {render::Colormap::coolwarm, 0.0},
      {render::Colormap::coolwarm, 0.3}, {render::Colormap::coolwarm, 1.0}};
  for (const auto& [map, t] : cases) {
    SCOPED_TRACE(fmt::format("{} t = {}", render::colormap_name(map), t));
    std::string range;
    if (t == 0.0)
      range = fmt::format("{}:{}", x_hi_ + 1e5, x_hi_ + 2e5);  // every particle below lo
    else if (t == 1.0)
      range = fmt::format("{}:{}", x_lo_ - 2e5, x_lo_ - 1e5);  // every particle above hi
    else
      range = fmt::format("{:.17g}:{:.17g}", c - t * wide, c + (1.0 - t) * wide);
    const std::vector<float> typed = render("typed", map_types(map, t));
    for (const char* where : {"", "--gpu-budget 64MiB"}) {
      SCOPED_TRACE(where);
      const std::vector<float> mapped = render("mapped", "--color-by x --color-range " + range + " --colormap " +
                                                             render::colormap_name(map) + " " + where);
      ASSERT_EQ(mapped.size(), typed.size());
      double worst = 0.0;
      size_t covered = 0;
      for (size_t i = 0; i < typed.size(); ++i) {
        worst = std::max(worst, double(std::abs(mapped[i] - typed[i])));
        covered += (i % 4 == 3 && typed[i] > 0.5f);
      }
      EXPECT_GT(covered, typed.size() / 16);
      EXPECT_LT(worst, 2e-4);
    }
  }
}

// Colour by x over the data's bounds on the default front view (x runs left to right): the
// left columns' particles are violet-blue (blue above red and green's mean), the right ones'
// yellow (red and green far above blue). Linear colours, summed over the covered pixels.
TEST_F(ColorMapRender, ColourByXRunsFromVioletToYellowAcrossTheImage) {
  const int w = 96, h = 72;
  const std::vector<float> img = render("gradient", "--color-by x --view 0");
  ASSERT_EQ(img.size(), size_t(4 * w * h));
  auto band = [&](int x0, int x1) {
    glm::dvec3 s(0.0);
    for (int y = 0; y < h; ++y)
      for (int x = x0; x < x1; ++x) {
        const float* p = &img[4 * (size_t(y) * w + x)];
        if (p[3] > 0.5f) s += glm::dvec3(p[0], p[1], p[2]);
      }
    return s;
  };
  const glm::dvec3 left = band(0, w / 5), right = band(w - w / 5, w);
  ASSERT_GT(left.b, 0.0);
  ASSERT_GT(right.r, 0.0);
  EXPECT_GT(left.b, 0.5 * (left.r + left.g)) << "left: " << left.r << " " << left.g << " " << left.b;
  EXPECT_GT(right.r + right.g, 4.0 * right.b) << "right: " << right.r << " " << right.g << " " << right.b;
}

TEST_F(ColorMapRender, BadOptionsAreUsageErrors) {
  EXPECT_NE(run_mdstream("render " + store_ + " --color-by speed -o " + (dir_ / "b.png").string()), 0);
  EXPECT_NE(cli_stderr().find("--color-by 'speed'"), std::string::npos) << cli_stderr();
  EXPECT_NE(run_mdstream("render " + store_ + " --color-by z --color-range 3:1 -o " + (dir_ / "b.png").string()), 0);
  EXPECT_NE(cli_stderr().find("--color-range '3:1'"), std::string::npos) << cli_stderr();
  EXPECT_NE(run_mdstream("render " + store_ + " --color-range 0:1 -o " + (dir_ / "b.png").string()), 0);
  EXPECT_NE(cli_stderr().find("needs --color-by"), std::string::npos) << cli_stderr();
  EXPECT_NE(run_mdstream("render " + store_ + " --color-by z --colormap jet -o " + (dir_ / "b.png").string()), 0);
  EXPECT_NE(cli_stderr().find("--colormap 'jet'"), std::string::npos) << cli_stderr();
  EXPECT_NE(run_mdstream("render " + store_ + " --colormap magma -o " + (dir_ / "b.png").string()), 0);
  EXPECT_NE(cli_stderr().find("--colormap needs --color-by"), std::string::npos) << cli_stderr();
  EXPECT_FALSE(fs::exists(dir_ / "b.png"));
}
