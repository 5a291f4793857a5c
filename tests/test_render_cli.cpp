// `mdstream render` end to end on real components: synth -> convert -> render (headless Vulkan
// on the machine's device), PNG and EXR output, --stats JSON, and the error paths; `mdstream bench`.
#include <gtest/gtest.h>
#include <tinyexr.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <cmath>
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "overlay/canvas.h"
#include "render/colormap.h"

namespace fs = std::filesystem;

namespace {

int run(const std::string& args) { return mds::testing::run_mdstream(args); }

int run_env(const std::string& env, const std::string& args) {
  return mds::testing::run_mdstream(args + " >/dev/null", env);
}

std::string last_stderr() { return mds::testing::cli_stderr(); }

using mds::testing::load_exr;

// Runs `bench ARGS --spp-list 4 --reference-spp 4 --coverage exact --json JSON`: its one culled
// row must have converged with at most 1 % of its pixels beyond the renderer's tolerance of the
// every-particle reference.
void expect_culled_row_matches_reference(const std::string& args, const fs::path& json) {
  ASSERT_EQ(run("bench " + args + " --spp-list 4 --reference-spp 4 --coverage exact --json " + json.string() +
                " > /dev/null"),
            0)
      << last_stderr();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  size_t checked = 0;
  for (const auto& r : j.at("rows")) {
    if (r.at("mode").get<std::string>() != "culled") continue;
    ++checked;
    EXPECT_TRUE(r.at("converged").get<bool>()) << args;
    EXPECT_LE(r.at("differing_fraction").get<double>(), 0.01) << args << ": " << r.dump();
  }
  EXPECT_EQ(checked, 1u) << j.dump();
}

class RenderCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mds_render_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    ASSERT_EQ(run("synth --scene shell --particles 20000 -q -o " + (dir_ / "s.lammpstrj").string()), 0)
        << last_stderr();
    ASSERT_EQ(run("convert " + (dir_ / "s.lammpstrj").string() + " -o " + (dir_ / "s.mds").string()), 0)
        << last_stderr();
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string store() { return (dir_ / "s.mds").string(); }
  static fs::path dir_;
};
fs::path RenderCli::dir_;

}  // namespace

TEST_F(RenderCli, RendersPngWithStats) {
  const fs::path png = dir_ / "a.png", stats = dir_ / "a.json";
  ASSERT_EQ(run("render " + store() + " -o " + png.string() + " --no-cull --spp 2 --width 96 --height 64 --stats " +
                stats.string()),
            0)
      << last_stderr();
  ASSERT_TRUE(fs::exists(png));
  std::ifstream f(png, std::ios::binary);
  unsigned char h[24];
  f.read(reinterpret_cast<char*>(h), 24);
  EXPECT_EQ(h[1], 'P');
  EXPECT_EQ(h[2], 'N');
  EXPECT_EQ(h[3], 'G');
  const uint32_t w = (h[16] << 24) | (h[17] << 16) | (h[18] << 8) | h[19];
  const uint32_t hh = (h[20] << 24) | (h[21] << 16) | (h[22] << 8) | h[23];
  EXPECT_EQ(w, 96u);
  EXPECT_EQ(hh, 64u);
  std::ifstream js(stats);
  auto j = nlohmann::json::parse(js);
  EXPECT_EQ(j["particles"].get<uint64_t>(), 20000u);
  EXPECT_GT(j["meshlets"].get<uint64_t>(), 0u);
  EXPECT_EQ(j["spp"].get<uint32_t>(), 2u);
  EXPECT_EQ(j["width"].get<uint32_t>(), 96u);
  EXPECT_FALSE(j["device"].get<std::string>().empty());
  EXPECT_TRUE(j.contains("frame_ms_no_cull"));
  EXPECT_TRUE(j["pass_ms_median"].contains("draw"));
  EXPECT_TRUE(j["pass_ms_median"].contains("draw_list"));
  // The last pass of a frame: the visibility route's resolve or the attachment route's accumulate.
  const bool vis = j["pixel_route"].get<std::string>() == "visibility";
  EXPECT_TRUE(j["pass_ms_median"].contains(vis ? "resolve" : "accumulate"));
  EXPECT_FALSE(j["pass_ms_median"].contains(vis ? "accumulate" : "resolve"));
  // auto: compute + indirect draws, the mesh path only where the device has VK_EXT_mesh_shader
  // and MDSTREAM_PREFER_MESH=1 (render/mesh_sprites.h; the child inherits the variable).
  const char* prefer = std::getenv("MDSTREAM_PREFER_MESH");
  const bool mesh = j["mesh_shader_available"].get<bool>() && prefer && std::string(prefer) == "1";
  EXPECT_EQ(j["sprite_path"].get<std::string>(), mesh ? "mesh" : "compute");
}

// --mesh-shaders on a device without mesh shaders (lavapipe): a clear error, no image; a bad
// value is an error too; off always renders with the compute path.
TEST_F(RenderCli, MeshShaderSelection) {
  const fs::path png = dir_ / "m.png", stats = dir_ / "m.json";
  const std::string base = "render " + store() + " -o " + png.string() + " --no-cull --spp 1 --width 48 --height 32";
  EXPECT_NE(run(base + " --mesh-shaders maybe"), 0);
  EXPECT_NE(last_stderr().find("--mesh-shaders 'maybe'"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(png));
  ASSERT_EQ(run(base + " --mesh-shaders off --stats " + stats.string()), 0) << last_stderr();
  std::ifstream js(stats);
  auto j = nlohmann::json::parse(js);
  EXPECT_EQ(j["sprite_path"].get<std::string>(), "compute");
  const bool available = j["mesh_shader_available"].get<bool>();
  fs::remove(png);
  const int rc = run(base + " --mesh-shaders on");
  if (available) {
    EXPECT_EQ(rc, 0) << last_stderr();
  } else {
    EXPECT_NE(rc, 0);
    EXPECT_NE(last_stderr().find("VK_EXT_mesh_shader"), std::string::npos) << last_stderr();
    EXPECT_FALSE(fs::exists(png));
  }
}

TEST_F(RenderCli, ExrOutputHoldsCoverageInAlpha) {
  for (int view = 0; view < 3; ++view) {
    const fs::path exr = dir_ / ("v" + std::to_string(view) + ".exr");
    ASSERT_EQ(run("render " + store() + " -o " + exr.string() + " --no-cull --spp 2 --width 80 --height 60 --view " +
                  std::to_string(view) + (view == 1 ? " --ortho" : "")),
              0)
        << last_stderr();
    float* rgba = nullptr;
    int w = 0, h = 0;
    const char* err = nullptr;
    ASSERT_EQ(LoadEXR(&rgba, &w, &h, exr.c_str(), &err), TINYEXR_SUCCESS) << (err ? err : "");
    ASSERT_EQ(w, 80);
    ASSERT_EQ(h, 60);
    double coverage = 0;
    for (int i = 0; i < w * h; ++i) coverage += rgba[4 * i + 3];
    std::free(rgba);
    // Every default view looks at the data: a visible part of the image is covered, not all.
    EXPECT_GT(coverage / (w * h), 0.05) << "view " << view;
    if (view < 2) {
      EXPECT_LT(coverage / (w * h), 0.95) << "view " << view;
    }
  }
}

// Without --no-cull the occlusion culling loop runs (render/culling) and reports its statistics.
TEST_F(RenderCli, WithoutNoCullRendersWithCullingStats) {
  const fs::path png = dir_ / "cull.png", stats = dir_ / "cull.json";
  ASSERT_EQ(run("render " + store() + " -o " + png.string() + " --spp 3 --width 32 --height 32 --max-iterations 3 " +
                "--samples-per-iteration 2 --stats " + stats.string()),
            0)
      << last_stderr();
  EXPECT_TRUE(fs::exists(png));
  std::ifstream f(stats);
  nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_EQ(j["no_cull"], false);
  EXPECT_EQ(j["iterations"], 3);  // --max-iterations 3 (convergence needs 3 quiet iterations)
  EXPECT_EQ(j["samples"], 6);     // 2 sampling passes per iteration
  EXPECT_EQ(j["parameters"]["samples_per_iteration"], 2);
  if (j["converged"].get<bool>()) {
    EXPECT_EQ(j["samples_to_converge"], 6);
  }
  EXPECT_GE(j["culled_fraction"].get<double>(), 0.0);
  EXPECT_LE(j["culled_fraction"].get<double>(), 1.0);
  EXPECT_EQ(j["parameters"]["acceptance"], "normal");
  EXPECT_NE(run("render " + store() + " -o " + png.string() + " --acceptance coin"), 0);
}

// --visible-reference: the meshlets holding a visible particle of the last frame, from that
// frame's depth. They were drawn in it, so they are a subset of the meshlets the culling kept;
// the shell's far half hides behind its near half, so the set is a strict part of all meshlets.
TEST_F(RenderCli, VisibleReferenceCountsVisibleMeshlets) {
  const fs::path png = dir_ / "vis.png", stats = dir_ / "vis.json", png_nc = dir_ / "visnc.png",
                 stats_nc = dir_ / "visnc.json";
  const std::string base = "render " + store() + " --spp 2 --width 96 --height 64 --visible-reference ";
  ASSERT_EQ(run(base + "-o " + png.string() + " --stats " + stats.string()), 0) << last_stderr();
  ASSERT_EQ(run(base + "--no-cull -o " + png_nc.string() + " --stats " + stats_nc.string()), 0) << last_stderr();
  std::ifstream f(stats), fnc(stats_nc);
  const nlohmann::json j = nlohmann::json::parse(f), jnc = nlohmann::json::parse(fnc);
  const uint64_t meshlets = j["meshlets"], culled = j["meshlets_culled"], visible = j["visible_meshlets"];
  EXPECT_GT(visible, 0u);
  EXPECT_LE(visible, meshlets - culled);
  EXPECT_GE(j["kept_over_visible_meshlets"].get<double>(), 1.0);
  const uint64_t visible_nc = jnc["visible_meshlets"];
  EXPECT_GT(visible_nc, 0u);
  EXPECT_LT(visible_nc, meshlets / 2) << "a shell shows less than half of itself";
  EXPECT_FALSE(jnc.contains("kept_over_visible_meshlets"));
  // node_granularity: the nodes with a visible particle drew it, so a meshlet of theirs is kept;
  // a node in O puts its meshlets in O, so the nodes with a kept meshlet are kept nodes.
  ASSERT_TRUE(j.contains("node_granularity"));
  const nlohmann::json& g = j["node_granularity"];
  EXPECT_EQ(g["visible_nodes"], j["visible_nodes"]);
  EXPECT_GT(g["visible_bytes"].get<uint64_t>(), 0u);
  EXPECT_GE(g["meshlet_kept_nodes"].get<uint64_t>(), g["visible_nodes"].get<uint64_t>());
  EXPECT_GE(g["meshlet_kept_bytes"].get<uint64_t>(), g["visible_bytes"].get<uint64_t>());
  EXPECT_GE(g["node_kept_nodes"].get<uint64_t>(), g["meshlet_kept_nodes"].get<uint64_t>());
  EXPECT_GE(g["node_kept_bytes"].get<uint64_t>(), g["meshlet_kept_bytes"].get<uint64_t>());
  EXPECT_GE(g["node_kept_over_visible"].get<double>(), 1.0);
  EXPECT_FALSE(jnc.contains("node_granularity"));  // --no-cull: no classes
}

// --color-legend: the legend is drawn into the image in its corner (stats: color_legend.box) and
// nowhere else -- every pixel outside the box is the image without it, to the bit (EXR floats).
// With types, type 1's --type-color fills its swatch (7 x 7 at this size); with --color-by z the
// bar holds viridis(0) and viridis(1). A bad corner fails before any image is written.
TEST_F(RenderCli, ColorLegendIsDrawnIntoItsCornerOnly) {
  const std::string base = "render " + store() + " --no-cull --spp 1 --width 160 --height 120 ";
  // A pixel of the legend as the 8-bit sRGB value it was drawn with (overlay::Canvas round trip).
  const auto srgb8 = [](const float* q) {
    return mds::overlay::Rgba8(mds::overlay::linear_to_srgb8(q[0]), mds::overlay::linear_to_srgb8(q[1]),
                               mds::overlay::linear_to_srgb8(q[2]), 255);
  };
  const auto viridis8 = [](double t) {
    const glm::dvec3 v = mds::render::viridis_srgb(t);
    auto b = [](double x) { return uint8_t(std::lround(std::clamp(x, 0.0, 1.0) * 255.0)); };
    return mds::overlay::Rgba8(b(v.r), b(v.g), b(v.b), 255);
  };
  for (const std::string look : {"--type-color 1=#ff00ff", "--color-by z"}) {
    SCOPED_TRACE(look);
    const fs::path plain = dir_ / "leg0.exr", drawn = dir_ / "leg1.exr", stats = dir_ / "leg.json";
    ASSERT_EQ(run(base + look + " -o " + plain.string()), 0) << last_stderr();
    ASSERT_EQ(run(base + look + " --color-legend top-right -o " + drawn.string() + " --stats " + stats.string()), 0)
        << last_stderr();
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(stats));
    ASSERT_EQ(j["color_legend"]["corner"], "top-right");
    const auto b = j["color_legend"]["box"].get<std::vector<int>>();
    ASSERT_EQ(b.size(), 4u);
    EXPECT_EQ(b[2], 160 - 8) << "the right margin";
    EXPECT_EQ(b[1], 8) << "the top margin";
    const std::vector<float> a = load_exr(plain), c = load_exr(drawn);
    ASSERT_EQ(a.size(), size_t(4) * 160 * 120);
    ASSERT_EQ(c.size(), a.size());
    size_t differ = 0, magenta = 0, viridis0 = 0, viridis1 = 0;
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 160; ++x) {
        const float* p = &a[4 * (size_t(y) * 160 + x)];
        const float* q = &c[4 * (size_t(y) * 160 + x)];
        const bool inside = x >= b[0] && x < b[2] && y >= b[1] && y < b[3];
        if (!inside) {
          ASSERT_EQ(std::memcmp(p, q, 4 * sizeof(float)), 0) << x << "," << y;
          continue;
        }
        EXPECT_EQ(q[3], 1.0f);
        differ += std::memcmp(p, q, 3 * sizeof(float)) != 0;
        magenta += srgb8(q) == mds::overlay::Rgba8(255, 0, 255, 255);
        viridis0 += srgb8(q) == viridis8(0.0);
        viridis1 += srgb8(q) == viridis8(1.0);
      }
    EXPECT_GT(differ, size_t(b[2] - b[0]) * size_t(b[3] - b[1]) / 2);
    if (look.find("type-color") != std::string::npos) {
      EXPECT_EQ(magenta, 49u);
    } else {
      EXPECT_GE(viridis0, 10u);  // a row of the 10 px bar at least
      EXPECT_GE(viridis1, 10u);
    }
  }
  const fs::path bad = dir_ / "leg_bad.png";
  EXPECT_EQ(run(base + "--color-legend middle -o " + bad.string()), 2);
  EXPECT_NE(last_stderr().find("--color-legend 'middle'"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(bad));
}

// --type-color, in memory and streamed: the same view with every type black and then red. A
// sprite's colour is type colour * diffuse + white specular (sphere_shading.h), so green, blue and
// coverage stay the same to the bit, and red grows exactly where a sphere covers the pixel. A key
// that names no type, or a bad colour, fails before any image is written.
TEST_F(RenderCli, TypeColorsRecolourEveryPath) {
  const std::string all_types[2] = {"#000000", "#ff0000"};
  for (const std::string mode : {"", "--gpu-budget 64MiB "}) {
    std::vector<float> img[2];
    for (int k = 0; k < 2; ++k) {
      const fs::path exr = dir_ / ("tc" + std::to_string(k) + ".exr");
      std::string colors;
      for (int t = 1; t <= 4; ++t) colors += " --type-color " + std::to_string(t) + "=" + all_types[k];
      ASSERT_EQ(run("render " + store() + " -o " + exr.string() + " --no-cull --cell off --spp 2 --width 80 --height 60 " + mode +
                    colors),
                0)
          << last_stderr();
      img[k] = load_exr(exr);
    }
    ASSERT_EQ(img[0].size(), size_t(4) * 80 * 60);
    ASSERT_EQ(img[0].size(), img[1].size());
    size_t covered = 0, redder = 0;
    for (size_t p = 0; p < img[0].size() / 4; ++p) {
      const float* a = &img[0][4 * p];
      const float* b = &img[1][4 * p];
      ASSERT_EQ(a[1], b[1]) << mode << "pixel " << p;
      ASSERT_EQ(a[2], b[2]) << mode << "pixel " << p;
      ASSERT_EQ(a[3], b[3]) << mode << "pixel " << p;
      if (a[3] == 0.0f) {
        EXPECT_EQ(a[0], b[0]) << mode << "background pixel " << p;
      } else {
        ++covered;
        redder += b[0] > a[0];
      }
    }
    EXPECT_GT(covered, 80u * 60u / 20u) << mode;
    EXPECT_EQ(redder, covered) << mode;
  }
  const fs::path png = dir_ / "tc_bad.png";
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --no-cull --type-color 9=#ff0000"), 2);
  EXPECT_NE(last_stderr().find("--type-color: no type '9' in the store (its types: 1, 2, 3, 4)"), std::string::npos)
      << last_stderr();
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --no-cull --type-color 1=#ff00"), 2);
  EXPECT_NE(last_stderr().find("'#ff00'"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(png));
  // `info` lists the colour each type takes by default.
  ASSERT_EQ(run("info " + store() + " --json > " + (dir_ / "info.json").string()), 0) << last_stderr();
  std::ifstream f(dir_ / "info.json");
  const nlohmann::json info = nlohmann::json::parse(f);
  EXPECT_EQ(info["types"][0]["color"].get<std::string>(), "#4e79a7");
  EXPECT_EQ(info["types"][2]["color"].get<std::string>(), "#e15759");
}

// --hide-type: the hidden type's particles are neither drawn nor occlude. The shell scene's type 1
// is the shell around types 2-4. Drawn red on black with the other types black, an image without
// type 1 has no red at all (a black sprite adds the same white highlight to every channel); with
// it, red shows. Culled, the view of the interior converges to its every-particle reference
// (bench: the culled row's pixels beyond the tolerance), which needs the culling's occluders and
// density volume to hold the shown types only. Streaming or every type hidden is a usage error.
TEST_F(RenderCli, HiddenTypesNeitherDrawNorOcclude) {
  const std::string look = " --background 0,0,0 --type-color 1=#ff0000 --type-color 2=#000000 --type-color 3=#000000 "
                           "--type-color 4=#000000";
  size_t red[2] = {0, 0};
  for (int hide = 0; hide < 2; ++hide) {
    const fs::path exr = dir_ / ("hide" + std::to_string(hide) + ".exr");
    ASSERT_EQ(run("render " + store() + " -o " + exr.string() + " --no-cull --spp 2 --width 80 --height 60" + look +
                  (hide ? " --hide-type 1" : "")),
              0)
        << last_stderr();
    const std::vector<float> rgba = load_exr(exr);
    ASSERT_EQ(rgba.size(), size_t(4) * 80 * 60);
    size_t covered = 0;
    for (size_t p = 0; p < rgba.size(); p += 4) {
      red[hide] += rgba[p] != rgba[p + 1];
      covered += rgba[p + 3] > 0.0f;
    }
    EXPECT_GT(covered, size_t(80 * 60) / 20) << "hide " << hide;
  }
  EXPECT_GT(red[0], 80u * 60u / 20u);
  EXPECT_EQ(red[1], 0u);

  expect_culled_row_matches_reference(store() + " --view 0 --width 64 --height 48 --hide-type 1",
                                      dir_ / "bench_hidden.json");

  const fs::path png = dir_ / "hide_bad.png";
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --hide-type 1 --gpu-budget 64MiB"), 2);
  EXPECT_NE(last_stderr().find("--hide-type needs the whole store in memory"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("render " + store() + " -o " + png.string() +
                " --hide-type 1 --hide-type 2 --hide-type 3 --hide-type 4"),
            2);
  EXPECT_NE(last_stderr().find("every type of the store is hidden"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(png));
}

// --type-radius: the particles of a type drawn at another radius, in memory. Smaller spheres leave
// gaps in the shell scene's dense surfaces; the culling (meshlet boxes, occupancy and footprint
// radius from the new radii) converges to the every-particle reference at those radii; streaming
// is a usage error.
TEST_F(RenderCli, TypeRadiiResizeDrawingAndCulling) {
  double coverage[2] = {0.0, 0.0};
  for (int k = 0; k < 2; ++k) {
    const fs::path exr = dir_ / ("radius" + std::to_string(k) + ".exr");
    ASSERT_EQ(run("render " + store() + " -o " + exr.string() + " --no-cull --spp 2 --width 80 --height 60" +
                  (k ? " --type-radius 1=0.15 --type-radius 2=0.15 --type-radius 3=0.15 --type-radius 4=0.15" : "")),
              0)
        << last_stderr();
    const std::vector<float> rgba = load_exr(exr);
    for (size_t p = 3; p < rgba.size(); p += 4) coverage[k] += rgba[p];
  }
  EXPECT_LT(coverage[1], 0.8 * coverage[0]) << "radius 0.15 against the store's 0.5: gaps between the spheres";
  EXPECT_GT(coverage[1], 0.0);

  expect_culled_row_matches_reference(store() + " --view 2 --width 64 --height 48 --type-radius 1=0.3 --type-radius 3=1.1",
                                      dir_ / "bench_radius.json");
  const fs::path png = dir_ / "radius_bad.png";
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --type-radius 1=0.3 --gpu-budget 64MiB"), 2);
  EXPECT_NE(last_stderr().find("--type-radius needs the whole store in memory"), std::string::npos) << last_stderr();
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --type-radius 1=0"), 2);
  EXPECT_FALSE(fs::exists(png));
}

// A streaming render whose pool cannot hold the view says so on stderr (the image lacks the
// nodes that did not fit) and in its stats; one whose pool holds the view says nothing.
TEST_F(RenderCli, StreamingRenderWarnsWhenThePoolCannotHoldTheView) {
  const fs::path small = dir_ / "s2k.mds";
  ASSERT_EQ(run("convert " + (dir_ / "s.lammpstrj").string() + " --node-size 2000 -q -o " + small.string()), 0)
      << last_stderr();
  const std::string base = "render " + small.string() + " --spp 2 --width 96 --height 64 ";
  const fs::path png = dir_ / "pool.png", stats = dir_ / "pool.json";
  ASSERT_EQ(run(base + "--gpu-budget 64MiB -o " + png.string() + " --stats " + stats.string()), 0) << last_stderr();
  EXPECT_EQ(last_stderr().find("warning"), std::string::npos) << last_stderr();
  nlohmann::json full;
  {
    std::ifstream f(stats);
    full = nlohmann::json::parse(f);
  }
  EXPECT_FALSE(full["budget_exhausted"].get<bool>());
  EXPECT_FALSE(full["gpu_pool_device_capped"].get<bool>());
  const uint64_t wanted = full["wanted_bytes"];
  ASSERT_GT(full["wanted_nodes"].get<uint64_t>(), 2u);
  EXPECT_LE(wanted, full["gpu_pool_bytes"].get<uint64_t>());

  // Half the pool pages of the nodes the converged view wants: some of them cannot be resident.
  const fs::path png2 = dir_ / "pool2.png", stats2 = dir_ / "pool2.json";
  ASSERT_EQ(run(base + "--gpu-budget " + std::to_string(wanted / 2) + " -o " + png2.string() + " --stats " +
                stats2.string()),
            0)
      << last_stderr();
  const std::string err = last_stderr();
  EXPECT_NE(err.find("warning: the image is incomplete"), std::string::npos) << err;
  EXPECT_NE(err.find("--gpu-budget"), std::string::npos) << err;
  std::ifstream f2(stats2);
  const nlohmann::json half = nlohmann::json::parse(f2);
  EXPECT_TRUE(half["budget_exhausted"].get<bool>());
  EXPECT_GT(half["wanted_bytes"].get<uint64_t>(), half["gpu_pool_bytes"].get<uint64_t>());
  EXPECT_LE(half["gpu_peak_bytes"].get<uint64_t>(), half["gpu_budget_bytes"].get<uint64_t>());
}

// cull_classify_coop.comp (box tests shared by a subgroup) against one thread per box, with every
// box shared (MDSTREAM_CULL_COOP_TEXELS=1: the full-box texel loop, the occupancy cells split over
// the lanes, their sub-cells, meshlets too), on a porous store of small nodes: the same classes
// in every culling iteration (counts changed and culled per iteration, final class counts) from
// the front view and the close-up. Only the summation order of a box's mean confidence differs,
// which moved no class on lavapipe or the H200. Fails when a lane's share of the texels or cells is
// skipped (tried: every other round skipped) or when the round that found a texel in front does
// not end the test on every lane. The shared variant runs twice: nodes one subgroup each
// (push.mode 2, the default) and nodes one thread each in subgroup-shared rounds
// (MDSTREAM_CULL_NODE_SUBGROUP=0, mode 0); a node skipped or tested twice by mode 2's indexing
// changes the node classes and so the meshlets'.
TEST_F(RenderCli, SharedBoxTestsClassifyLikeOneThreadPerBox) {
  const fs::path dump = dir_ / "porous.lammpstrj", porous = dir_ / "porous.mds";
  ASSERT_EQ(run("synth --scene porous --particles 60000 -q -o " + dump.string()), 0) << last_stderr();
  ASSERT_EQ(run("convert " + dump.string() + " --node-size 1000 -q -o " + porous.string()), 0) << last_stderr();
  // One thread per box; shared tests with a subgroup per node; shared tests with one thread per
  // node; each of the two with the shared cells (kSharedCells, the default where tests are shared:
  // a node's occupied cells one after the other, each cell's texels over the subgroup).
  const char* variants[5] = {"MDSTREAM_CULL_COOP_BOXES=0 ", "MDSTREAM_CULL_COOP_BOXES=1 MDSTREAM_CULL_SHARED_CELLS=0 ",
                             "MDSTREAM_CULL_COOP_BOXES=1 MDSTREAM_CULL_NODE_SUBGROUP=0 MDSTREAM_CULL_SHARED_CELLS=0 ",
                             "MDSTREAM_CULL_COOP_BOXES=1 ",
                             "MDSTREAM_CULL_COOP_BOXES=1 MDSTREAM_CULL_NODE_SUBGROUP=0 "};
  for (int view : {0, 2}) {
    SCOPED_TRACE("view " + std::to_string(view));
    nlohmann::json j[5];
    for (int v = 0; v < 5; ++v) {
      const fs::path png = dir_ / "shared.png", stats = dir_ / ("shared" + std::to_string(v) + ".json");
      ASSERT_EQ(run_env(std::string("MDSTREAM_CULL_COOP_TEXELS=1 ") + variants[v],
                        "render " + porous.string() + " -o " + png.string() + " --width 160 --height 120 --spp 8 --view " +
                            std::to_string(view) + " --stats " + stats.string()),
                0)
          << last_stderr();
      std::ifstream f(stats);
      j[v] = nlohmann::json::parse(f);
    }
    EXPECT_FALSE(j[0]["parameters"]["shared_box_tests"].get<bool>());
    EXPECT_FALSE(j[0]["parameters"]["node_per_subgroup"].get<bool>());
    if (!j[1]["parameters"]["shared_box_tests"].get<bool>()) GTEST_SKIP() << "no subgroup ballot + shuffle + add in compute";
    EXPECT_TRUE(j[1]["parameters"]["node_per_subgroup"].get<bool>());
    EXPECT_FALSE(j[2]["parameters"]["node_per_subgroup"].get<bool>());
    for (int v : {0, 1, 2}) EXPECT_FALSE(j[v]["parameters"]["shared_cells"].get<bool>());
    for (int v : {3, 4}) EXPECT_TRUE(j[v]["parameters"]["shared_cells"].get<bool>());
    for (int v : {1, 2, 3, 4}) {
      SCOPED_TRACE(variants[v]);
      for (const char* k : {"changed_per_iteration", "culled_per_iteration", "class_counts", "iterations"})
        EXPECT_EQ(j[0][k], j[v][k]) << k;
      EXPECT_GT(j[v]["culled_fraction"].get<double>(), 0.0);
    }
  }
}

TEST_F(RenderCli, BadCameraAndMissingStoreFailCleanly) {
  const fs::path png = dir_ / "bad.png";
  EXPECT_EQ(run("render " + store() + " -o " + png.string() + " --no-cull --camera 1,2,3"), 2);
  EXPECT_NE(last_stderr().find("--camera"), std::string::npos);
  EXPECT_NE(run("render " + (dir_ / "missing.mds").string() + " -o " + png.string() + " --no-cull"), 0);
  EXPECT_NE(last_stderr().find("missing.mds"), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(png));
}

// The Vulkan commands live in libmdstream_vulkan.so (cli/vulkan_module.h): without it `render`
// fails naming every place looked in and writes nothing, while `info` (no module) still works,
// and the top-level help still lists the commands of the executable.
TEST_F(RenderCli, RenderWithoutItsModuleFailsCleanly) {
  const fs::path empty = dir_ / "empty";
  fs::create_directories(empty);
  const fs::path png = dir_ / "nomodule.png";
  const std::string env = "MDSTREAM_MODULE_DIR=" + empty.string() + " ";
  EXPECT_NE(run_env(env, "render " + store() + " -o " + png.string() + " --no-cull"), 0);
  EXPECT_NE(last_stderr().find((empty / "libmdstream_vulkan.so").string()), std::string::npos) << last_stderr();
  EXPECT_FALSE(fs::exists(png));
  EXPECT_EQ(run_env(env, "info " + store()), 0) << last_stderr();
  // With the module, the help lists its commands next to the executable's own.
  const fs::path help = dir_ / "help.txt";
  ASSERT_EQ(std::system((std::string(MDSTREAM_BIN) + " --help > " + help.string()).c_str()), 0);
  std::ifstream f(help);
  const std::string text((std::istreambuf_iterator<char>(f)), {});
  for (const char* c : {"bench", "convert", "export", "info", "render", "stress", "synth", "view"})
    EXPECT_NE(text.find(std::string("\n  ") + c), std::string::npos) << c << "\n" << text;
}

// --coverage auto (the default) takes each occlusion sample's area by its own particle's
// projected size: exact clipping below 2 pixels, the expected area above. In a thumbnail of the
// shell every particle is below 2 pixels, and auto's classes are exact's; in a narrow (10 degree)
// close-up at 480x270 the particles that take the samples are larger, and auto's classes are the
// expected area's. The two models classify differently in both views, so the equalities are not
// trivial.
TEST_F(RenderCli, CoverageAutoClipsOnlyParticlesBelowTwoPixels) {
  const auto classes = [&](const std::string& args) -> std::string {
    const fs::path png = dir_ / "cov.png", stats = dir_ / "cov.json";
    if (run("render " + store() + " -o " + png.string() + " --spp 1 --max-iterations 2 " + args + " --stats " +
            stats.string()) != 0)
      return "render failed: " + last_stderr();
    std::ifstream f(stats);
    const auto j = nlohmann::json::parse(f, nullptr, false);
    if (j.is_discarded()) return "no stats";
    return j["parameters"]["coverage"].get<std::string>() == args.substr(args.rfind(' ') + 1)
               ? j["class_counts"].dump()
               : "parameters.coverage is not the one asked for";
  };
  const std::string thumb = "--view 0 --width 48 --height 32 --coverage ";
  const std::string close = "--view 2 --width 480 --height 270 --fov 10 --coverage ";
  EXPECT_NE(classes(thumb + "exact"), classes(thumb + "expected"));
  EXPECT_EQ(classes(thumb + "auto"), classes(thumb + "exact"));
  EXPECT_NE(classes(close + "exact"), classes(close + "expected"));
  EXPECT_EQ(classes(close + "auto"), classes(close + "expected"));
}

// `mdstream bench`: every row is compared with the reference (every particle at
// --reference-spp). The row with the reference's settings reproduces it exactly on a CPU device
// (on a GPU the atomics' order breaks exact depth ties differently between the two renders, as in
// test_cull_render.cpp, so there at most 0.1 % of its pixels may differ beyond 0.1), fewer samples
// do not, and on the close-up, where culling removes most meshlets, the image of the converged
// meshlet classes at the reference's spp stays within the renderer's own tolerance (at most 1 %
// of the pixels beyond 0.1, as test_cull_render.cpp requires of culled renders) with either
// sample-area model; at 1 spp it differs from the reference about as much as the unculled one.
// Exact coverage culls less than the paper's expected area and loses no more pixels; with it the
// particle occlusion test stays within the tolerance too (with the expected area it is measured,
// not bounded: docs/rendering.md, "What accuracy costs in time").
TEST_F(RenderCli, BenchComparesEveryRowWithTheReference) {
  const fs::path csv = dir_ / "bench.csv";
  const fs::path json = dir_ / "bench.json";
  ASSERT_EQ(run("bench " + store() + " --view 2 --width 64 --height 48 --spp-list 1,4 --reference-spp 4 " +
                "--particle-occlusion on --csv " + csv.string() + " --json " + json.string() + " > /dev/null"),
            0)
      << last_stderr();
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  const bool cpu_device = j.at("device_type").get<std::string>() == "cpu";
  std::ifstream f(csv);
  std::string line;
  std::getline(f, line);
  ASSERT_EQ(line.rfind("mode,coverage,spp,wall_ms,gpu_frame_ms,", 0), 0u) << line;
  std::map<std::string, std::vector<std::string>> rows;  // "mode@coverage/spp"
  while (std::getline(f, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    if (line.back() == ',') cells.push_back("");
    ASSERT_EQ(cells.size(), 13u) << line;
    rows[cells[0] + (cells[1].empty() ? "" : "@" + cells[1]) + "/" + cells[2]] = cells;
  }
  ASSERT_EQ(rows.size(), 10u);
  const auto rmse = [&](const std::string& k) { return std::stod(rows.at(k)[8]); };
  const auto beyond = [&](const std::string& k) { return std::stod(rows.at(k)[12]); };
  const auto culled = [&](const std::string& k) { return std::stod(rows.at(k)[7]); };
  if (cpu_device) {
    EXPECT_EQ(rmse("all/4"), 0.0);
    EXPECT_EQ(rows.at("all/4")[9], "inf");
  } else {
    EXPECT_LE(beyond("all/4"), 0.001) << "on " << j.at("device").get<std::string>();
  }
  EXPECT_GT(rmse("all/1"), 0.0);
  for (const std::string cov : {"expected", "exact"}) {
    EXPECT_LE(beyond("culled@" + cov + "/4"), 0.01) << cov;
    EXPECT_LE(beyond("culled@" + cov + "/1"), beyond("all/1") + 0.01) << cov;
    for (const std::string mode : {"culled", "culled+particles"})
      for (const char* spp : {"/1", "/4"}) {
        const std::string k = mode + "@" + cov + spp;
        EXPECT_EQ(rows.at(k)[6], "1") << k << ": converged";
        EXPECT_GT(culled(k), 0.2) << k << ": culled fraction";
      }
  }
  EXPECT_GT(culled("culled@expected/4"), culled("culled@exact/4"));
  EXPECT_LE(beyond("culled@exact/4"), beyond("culled@expected/4"));
  EXPECT_LE(beyond("culled+particles@exact/4"), beyond("culled+particles@expected/4"));
  // With exact coverage the particle occlusion test also stays within the tolerance (the
  // expected area lets it drop visible particles: 5 % of this image's pixels, docs/rendering.md).
  EXPECT_LE(beyond("culled+particles@exact/4"), 0.01);
  // Bad values are usage errors.
  EXPECT_EQ(run("bench " + store() + " --spp-list 0"), 2);
  EXPECT_NE(run("bench " + (dir_ / "missing.mds").string()), 0);
  EXPECT_NE(last_stderr().find("missing.mds"), std::string::npos) << last_stderr();
}
