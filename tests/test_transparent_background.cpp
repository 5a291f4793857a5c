// `render --background transparent` (render/image_io.h): the PNG gets an alpha channel with
// straight colour and the EXR premultiplied colour, such that composing either over a background
// gives the render made with that background; the alpha is the render's coverage (0 where no
// sample met a particle, 1 where every one did), for a single image and for every frame of a
// camera path; opaque renders stay RGB.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "render/scene.h"

namespace mds {
namespace {

using ::testing::HasSubstr;
using testing::cli_stderr;
using testing::load_exr;
using testing::run_mdstream;
namespace fs = std::filesystem;

struct Png {
  uint32_t width = 0, height = 0, channels = 0;  // channels as stored (3: RGB, 4: RGBA)
  std::vector<uint8_t> rgba;                     // 4 per pixel
};

Png read_png(const fs::path& path) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  Png out;
  if (!png_image_begin_read_from_file(&img, path.c_str())) return out;
  out.channels = PNG_IMAGE_SAMPLE_CHANNELS(img.format);
  img.format = PNG_FORMAT_RGBA;
  out.rgba.resize(PNG_IMAGE_SIZE(img));
  if (!png_image_finish_read(&img, nullptr, out.rgba.data(), 0, nullptr)) return {};
  out.width = img.width;
  out.height = img.height;
  return out;
}

class TransparentBackground : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mds_transparent_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    ASSERT_EQ(run_mdstream("synth --scene shell --particles 6000 -q -o " + (dir_ / "s.lammpstrj").string()), 0)
        << cli_stderr();
    ASSERT_EQ(run_mdstream("convert -q " + (dir_ / "s.lammpstrj").string() + " -o " + store()), 0) << cli_stderr();
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string store() { return (dir_ / "s.mds").string(); }
  static fs::path dir_;
};
fs::path TransparentBackground::dir_;

constexpr uint32_t W = 96, H = 72;
const std::string kLook = " --width 96 --height 72 --spp 8 --no-cull --view 0";

TEST_F(TransparentBackground, ComposedOverABackgroundGivesTheRenderWithIt) {
  const glm::vec3 bg_srgb(0.2f, 0.4f, 0.8f);  // #3366cc
  ASSERT_EQ(run_mdstream("render " + store() + " -o " + (dir_ / "o.exr").string() + kLook + " --background 0.2,0.4,0.8"),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("render " + store() + " -o " + (dir_ / "o.png").string() + kLook + " --background 0.2,0.4,0.8"),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("render " + store() + " -o " + (dir_ / "t.exr").string() + kLook + " --background transparent"),
            0)
      << cli_stderr();
  ASSERT_EQ(run_mdstream("render " + store() + " -o " + (dir_ / "t.png").string() + kLook + " --background transparent"),
            0)
      << cli_stderr();
  const std::vector<float> opaque = load_exr(dir_ / "o.exr"), premul = load_exr(dir_ / "t.exr");
  const Png straight = read_png(dir_ / "t.png"), rgb = read_png(dir_ / "o.png");
  ASSERT_EQ(opaque.size(), size_t(4) * W * H);
  ASSERT_EQ(premul.size(), opaque.size());
  ASSERT_EQ(straight.width, W);
  EXPECT_EQ(straight.channels, 4u);
  EXPECT_EQ(rgb.channels, 3u);  // an opaque render stays RGB
  const glm::vec3 bg(render::srgb_to_linear(bg_srgb.r), render::srgb_to_linear(bg_srgb.g),
                     render::srgb_to_linear(bg_srgb.b));
  size_t empty = 0, full = 0, edge = 0;
  double worst_exr = 0, worst_png = 0;
  for (size_t p = 0; p < size_t(W) * H; ++p) {
    const float a = premul[4 * p + 3];
    EXPECT_EQ(a, opaque[4 * p + 3]) << p;  // the same coverage
    EXPECT_EQ(straight.rgba[4 * p + 3], uint8_t(std::lround(a * 255.0f))) << p;
    empty += a == 0.0f;
    full += a == 1.0f;
    edge += a > 0.0f && a < 1.0f;
    for (int c = 0; c < 3; ++c) {
      // EXR: premultiplied, over the background.
      worst_exr = std::max(worst_exr, double(std::abs(premul[4 * p + c] + bg[c] * (1.0f - a) - opaque[4 * p + c])));
      // PNG: straight sRGB colour and 8-bit alpha, composed in linear.
      const float sa = float(straight.rgba[4 * p + 3]) / 255.0f;
      const float sc = render::srgb_to_linear(float(straight.rgba[4 * p + c]) / 255.0f);
      worst_png = std::max(worst_png, double(std::abs(sc * sa + bg[c] * (1.0f - sa) - opaque[4 * p + c])));
    }
    if (a == 0.0f) {
      EXPECT_EQ(straight.rgba[4 * p + 0] + straight.rgba[4 * p + 1] + straight.rgba[4 * p + 2], 0) << p;
    }
  }
  EXPECT_GT(empty, size_t(W) * H / 10);  // the shell leaves the corners empty
  EXPECT_GT(full, size_t(W) * H / 10);
  EXPECT_GT(edge, 20u);  // anti-aliased edges: partly covered pixels
  EXPECT_LT(worst_exr, 1e-5);
  EXPECT_LT(worst_png, 3.0 / 255.0);  // 8-bit straight colour and alpha
}

TEST_F(TransparentBackground, EveryFrameOfAPathAndErrors) {
  ASSERT_EQ(run_mdstream("render " + store() + " -o " + (dir_ / "f_%d.png").string() +
                         " --width 32 --height 24 --spp 2 --no-cull --path orbit --frames 2 --background transparent"),
            0)
      << cli_stderr();
  for (const char* f : {"f_0.png", "f_1.png"}) {
    const Png png = read_png(dir_ / f);
    EXPECT_EQ(png.channels, 4u) << f;
    size_t clear = 0;
    for (size_t p = 0; p < png.rgba.size(); p += 4) clear += png.rgba[p + 3] == 0;
    EXPECT_GT(clear, 0u) << f;
  }
  EXPECT_EQ(run_mdstream("render " + store() + " -o " + (dir_ / "x.png").string() + " --background see-through"), 2);
  EXPECT_THAT(cli_stderr(), HasSubstr("--background"));
  EXPECT_THAT(cli_stderr(), HasSubstr("(or transparent)"));
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
}

}  // namespace
}  // namespace mds
