// The simulation cell drawn by `render` (render/cell_lines.h, cell_lines.vert/.frag) on lavapipe,
// against a CPU reference: a cubic cell around one large sphere, seen from the front. Points
// along the twelve edges are projected on the CPU with the renderer's own camera matrices
// (render/camera.h), and a ray through each point's pixel is tested against the sphere: where the
// sphere lies in front, the pixel must show the sphere, else the cell's colour. Both pixel routes
// (visibility buffer, attachments), in memory and streamed, give the same image; a camera inside
// the cell (edges crossing the near plane) draws lines only; --cell off/on/auto and bad values.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <glm/glm.hpp>

#include "cli_test_util.h"
#include "render/camera.h"
#include "scoped_temp_dir.h"

namespace mds {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::load_exr;
using testing::run_mdstream;

constexpr int W = 160, H = 120;
constexpr double kL = 10.0;  // the cubic cell [0, 10]^3
constexpr double kR = 4.9;   // the sphere at its centre (convert --radius)
const glm::dvec3 kCentre{5.0, 5.0, 5.0};

class CellLines : public ::testing::Test {
 protected:
  void SetUp() override {
    const fs::path xyz = tmp_.p / "box.xyz";
    std::ofstream f(xyz);
    f << "1\nLattice=\"10 0 0 0 10 0 0 0 10\" Properties=species:S:1:pos:R:3\nC 5 5 5\n";
    f.close();
    store_ = (tmp_.p / "box.mds").string();
    ASSERT_EQ(run_mdstream("convert -q " + xyz.string() + " -o " + store_ + " --radius 4.9"), 0) << cli_stderr();
    const fs::path plain = tmp_.p / "plain.xyz";
    std::ofstream g(plain);
    g << "1\nProperties=species:S:1:pos:R:3\nC 5 5 5\n";
    g.close();
    plain_ = (tmp_.p / "plain.mds").string();
    ASSERT_EQ(run_mdstream("convert -q " + plain.string() + " -o " + plain_ + " --radius 3"), 0) << cli_stderr();
  }

  // Renders to EXR (linear RGBA) with a red cell and a blue sphere on black; empty on failure.
  std::vector<float> render(const std::string& camera, const std::string& extra, const std::string& env = "") {
    const fs::path out = tmp_.p / ("r" + std::to_string(++count_) + ".exr");
    const int rc = run_mdstream("render " + store_ + " -o " + out.string() +
                                    fmt::format(" --width {} --height {} --spp 16 --no-cull --camera {}", W, H, camera) +
                                    " --background 0,0,0 --type-color C=#0000ff --cell-color 1,0,0 --cell-width 2 " +
                                    extra,
                                env);
    EXPECT_EQ(rc, 0) << cli_stderr();
    return rc == 0 ? load_exr(out) : std::vector<float>{};
  }

  test::ScopedTempDir tmp_{"mds_cell_lines_"};
  std::string store_, plain_;
  int count_ = 0;
};

bool red(const float* p) { return p[0] > 0.25f && p[1] < 0.02f && p[2] < 0.05f; }
bool blue(const float* p) { return p[2] > 0.05f && p[0] < 0.02f; }

TEST_F(CellLines, EdgesShowWhereNoSphereLiesInFront) {
  const std::string cam = "5,5,32,5,5,5";
  const std::vector<float> img = render(cam, "");
  ASSERT_EQ(img.size(), size_t(4) * W * H);

  render::Camera camera;
  camera.eye = {5, 5, 32};
  camera.target = kCentre;
  camera.fov_y_deg = 40.0;
  const glm::dmat4 vp = render::projection_matrix(camera, double(W) / H) * render::view_matrix(camera, glm::dvec3(0.0));
  const double px_world = 2.0 * (32.0 - 5.0) * std::tan(glm::radians(20.0)) / H;  // a pixel at the centre's depth
  int visible = 0, hidden = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int k = 0; k < 4; ++k)
      for (double t : {0.3, 0.5, 0.7}) {
        // Edge along `axis` at the corner offsets (k & 1, k >> 1) on the other two axes.
        glm::dvec3 p(0.0);
        p[axis] = t * kL;
        p[(axis + 1) % 3] = (k & 1) * kL;
        p[(axis + 2) % 3] = (k >> 1) * kL;
        const glm::dvec4 c = vp * glm::dvec4(p, 1.0);
        const glm::dvec2 pix = (glm::dvec2(c) / c.w + 1.0) * 0.5 * glm::dvec2(W, H);
        const int x = int(std::floor(pix.x)), y = int(std::floor(pix.y));
        if (x < 2 || y < 2 || x >= W - 2 || y >= H - 2) continue;
        // The ray through that point: the sphere in front of it, or not; near the silhouette
        // (within two pixels at the sphere's depth) the pixel may show either.
        const glm::dvec3 d = glm::normalize(p - camera.eye);
        const glm::dvec3 oc = kCentre - camera.eye;
        const double along = glm::dot(oc, d);
        const double miss = glm::length(oc - along * d);
        if (std::abs(miss - kR) < 2.0 * px_world) continue;
        const bool behind_sphere = miss < kR && along - std::sqrt(kR * kR - miss * miss) < glm::length(p - camera.eye);
        const float* q = &img[4 * (size_t(y) * W + x)];
        SCOPED_TRACE(fmt::format("edge axis {} k {} t {}: pixel ({}, {}) rgb {} {} {}", axis, k, t, x, y, q[0], q[1],
                                 q[2]));
        if (behind_sphere) {
          ++hidden;
          EXPECT_TRUE(blue(q)) << "hidden by the sphere";
        } else {
          ++visible;
          EXPECT_TRUE(red(q)) << "an edge in front of everything";
        }
      }
  // The front face's edges are seen, the back face's middles lie behind the sphere.
  EXPECT_GE(visible, 12);
  EXPECT_GE(hidden, 3);
}

TEST_F(CellLines, BothRoutesInMemoryAndStreamedDrawTheSameImage) {
  const std::string cam = "24,18,30,5,5,5";
  const std::vector<float> vis = render(cam, "");
  const std::vector<float> att = render(cam, "", "MDSTREAM_PIXEL_ROUTE=attachments ");
  const std::vector<float> streamed = render(cam, "--gpu-budget 1MiB");
  ASSERT_EQ(vis.size(), size_t(4) * W * H);
  ASSERT_EQ(att.size(), vis.size());
  ASSERT_EQ(streamed.size(), vis.size());
  size_t red_pixels = 0, differ_att = 0, differ_stream = 0;
  for (size_t i = 0; i < vis.size() / 4; ++i) {
    red_pixels += red(&vis[4 * i]);
    for (int c = 0; c < 4; ++c) {
      differ_att += std::abs(vis[4 * i + c] - att[4 * i + c]) > 1e-3f;
      differ_stream += std::abs(vis[4 * i + c] - streamed[4 * i + c]) > 1e-3f;
    }
  }
  EXPECT_GT(red_pixels, 200u);  // twelve edges, 2 px wide
  EXPECT_EQ(differ_att, 0u);
  EXPECT_EQ(differ_stream, 0u);
  // Off: not a single red pixel.
  const std::vector<float> off = render(cam, "--cell off");
  ASSERT_EQ(off.size(), vis.size());
  size_t red_off = 0;
  for (size_t i = 0; i < off.size() / 4; ++i) red_off += red(&off[4 * i]);
  EXPECT_EQ(red_off, 0u);
}

// The edges of the cell [0, 10]^3 as seen by `camera`, clipped to the space in front of it and
// projected to pixels (the CPU reference of cell_lines.vert's geometry).
std::vector<std::pair<glm::dvec2, glm::dvec2>> projected_edges(const render::Camera& camera) {
  const glm::dmat4 view = render::view_matrix(camera, glm::dvec3(0.0));
  const glm::dmat4 proj = render::projection_matrix(camera, double(W) / H);
  std::vector<std::pair<glm::dvec2, glm::dvec2>> out;
  for (int axis = 0; axis < 3; ++axis)
    for (int k = 0; k < 4; ++k) {
      glm::dvec3 a(0.0);
      a[(axis + 1) % 3] = (k & 1) * kL;
      a[(axis + 2) % 3] = (k >> 1) * kL;
      glm::dvec3 b = a;
      b[axis] = kL;
      glm::dvec4 va = view * glm::dvec4(a, 1.0), vb = view * glm::dvec4(b, 1.0);
      const double zn = -1e-3;  // just in front of the eye (view space looks along -z)
      if (va.z > zn && vb.z > zn) continue;
      if (va.z > zn) va = vb + (va - vb) * ((zn - vb.z) / (va.z - vb.z));
      if (vb.z > zn) vb = va + (vb - va) * ((zn - va.z) / (vb.z - va.z));
      auto to_px = [&](const glm::dvec4& v) {
        const glm::dvec4 c = proj * v;
        return (glm::dvec2(c) / c.w + 1.0) * 0.5 * glm::dvec2(W, H);
      };
      out.emplace_back(to_px(va), to_px(vb));
    }
  return out;
}

double distance_to_segment(glm::dvec2 p, glm::dvec2 a, glm::dvec2 b) {
  const glm::dvec2 ab = b - a;
  const double len2 = glm::dot(ab, ab);
  const double t = len2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + t * ab));
}

TEST_F(CellLines, ACameraInsideTheCellDrawsLinesOnly) {
  // From the middle of the face x = 0 towards +x: parts of the far face's edges and the edges
  // along x, which start in the eye's plane (w = 0 there: without cell_lines.vert's near-plane
  // clip they vanish). The sphere, made tiny, lies outside the view. Every red pixel lies on an
  // edge's projection (2 px wide), and the projections' pixels inside the image are red.
  const std::vector<float> img = render("0,8,8,10,8,8", "--type-radius C=0.01");
  ASSERT_EQ(img.size(), size_t(4) * W * H);
  render::Camera camera;
  camera.eye = {0, 8, 8};
  camera.target = {10, 8, 8};
  const auto edges = projected_edges(camera);
  size_t red_pixels = 0, off_edge = 0, on_edge = 0, on_edge_red = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float* q = &img[4 * (size_t(y) * W + x)];
      double d = 1e9;
      for (const auto& [a, b] : edges) d = std::min(d, distance_to_segment({x + 0.5, y + 0.5}, a, b));
      EXPECT_FALSE(q[1] > 0.02f || q[2] > 0.02f) << "pixel " << x << "," << y;
      if (q[0] > 0.02f) {
        ++red_pixels;
        off_edge += d > 2.5;
      }
      if (d < 0.5) {
        ++on_edge;
        on_edge_red += q[0] > 0.25f;
      }
    }
  EXPECT_GT(red_pixels, 150u);
  EXPECT_EQ(off_edge, 0u) << "red pixels away from every edge";
  EXPECT_GT(on_edge, 100u);
  EXPECT_GE(double(on_edge_red), 0.95 * double(on_edge));
  // The centre pixel looks at the far face's interior: no edge there.
  EXPECT_LT(img[4 * (size_t(H / 2) * W + W / 2)], 0.02f);
}

// A series whose frames do not all have a cell: --cell on is refused before any frame is
// written, and auto draws no cell in any frame (the cell does not come and go).
TEST_F(CellLines, ASeriesDrawsTheCellOnlyWhenEveryFrameHasOne) {
  const fs::path series = tmp_.p / "mixed.series";
  std::ofstream(series) << R"({"file-series-version": "1.0", "files": [{"name": "box.mds", "time": 0}, )"
                        << R"({"name": "plain.mds", "time": 1}]})";
  const std::string look = " --width 64 --height 48 --spp 2 --no-cull --camera 24,18,30,5,5,5";
  const fs::path frames = tmp_.p / "f_%d.exr";
  EXPECT_EQ(run_mdstream("render " + series.string() + " -o " + frames.string() + look + " --cell on"), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--cell on: not every picked frame of " + series.string() + " has a simulation cell"));
  EXPECT_FALSE(fs::exists(tmp_.p / "f_0.exr"));
  ASSERT_EQ(run_mdstream("render " + series.string() + " -o " + frames.string() + look), 0) << cli_stderr();
  const fs::path alone = tmp_.p / "alone.exr";
  ASSERT_EQ(run_mdstream("render " + store_ + " -o " + alone.string() + look + " --cell off"), 0) << cli_stderr();
  const std::vector<float> a = load_exr(tmp_.p / "f_0.exr"), b = load_exr(alone);
  ASSERT_EQ(a.size(), size_t(4) * 64 * 48);
  EXPECT_EQ(a, b);
}

TEST_F(CellLines, CellOptions) {
  const fs::path out = tmp_.p / "x.png";
  EXPECT_EQ(run_mdstream("render " + plain_ + " -o " + out.string() + " --width 32 --height 24 --spp 1 --cell on"), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--cell on: " + plain_ + " has no simulation cell"));
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(run_mdstream("render " + plain_ + " -o " + out.string() + " --width 32 --height 24 --spp 1"), 0)
      << cli_stderr();  // auto: nothing to draw
  EXPECT_EQ(run_mdstream("render " + store_ + " -o " + out.string() + " --cell maybe"), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--cell 'maybe': expected off, on or auto"));
  EXPECT_EQ(run_mdstream("render " + store_ + " -o " + out.string() + " --cell-color red"), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--cell-color"));
}

}  // namespace
}  // namespace mds
