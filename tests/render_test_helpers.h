// Test helpers for the rendering tests: a validated Vulkan context per suite, the renderer's
// image tolerance, and running the CLI.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "render/image_compare.h"
#include "render/renderer.h"
#include "store/store_reader.h"
#include "vk/context.h"

namespace mds::testing {

// The bounds a store's header gives (the particle centres) with its largest type radius: what
// the default views of a store are made from without decoding it.
inline render::Bounds header_bounds(const store::StoreReader& reader) {
  const auto& h = reader.header();
  render::Bounds b;
  b.min = {h.bounds_min[0], h.bounds_min[1], h.bounds_min[2]};
  b.max = {h.bounds_max[0], h.bounds_max[1], h.bounds_max[2]};
  for (const auto& t : reader.types()) b.radius_max = std::max(b.radius_max, double(t.radius));
  return b;
}

// What a test keeps of one render(): the averaged image, the last frame's depth
// (Renderer::read_last_depth) and the statistics.
struct RenderedFrame {
  render::FrameImage image;
  std::vector<float> depth;
  render::RenderStats stats;
};

// A suite sharing one Vulkan context with the Khronos validation layer (where installed); every
// test must end without a validation message.
class VulkanSuite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // With the Khronos layer installed: its synchronization validation too (missing or wrong
    // barriers between passes are hazards it reports; the layer reads this variable).
    setenv("VK_LAYER_ENABLES", "VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT", 0);
    vk::ContextOptions o;
    o.validation = true;
    auto c = vk::Context::create(o);
    ASSERT_TRUE(c.ok()) << c.error().message;
    ctx_ = std::move(c).value().release();
  }
  static void TearDownTestSuite() {
    delete ctx_;
    ctx_ = nullptr;
  }
  void TearDown() override { EXPECT_EQ(ctx_->validation_messages(), 0u); }
  static inline vk::Context* ctx_ = nullptr;
};

// Pixels whose colour differs by more than `tol` in some channel. 0.1 is the renderer's own
// tolerance for culled vs. unculled renders (test_cull_render.cpp: at most 1 % of the pixels).
// The count of render/image_compare.h, which `mdstream bench` reports (images of one size).
inline size_t differing_pixels(const render::FrameImage& a, const render::FrameImage& b,
                               float tol = render::kPixelTolerance) {
  return size_t(render::compare_images(a, b, tol).value().differing_pixels);
}

// Positions of a dense block: n spheres uniformly in a 20^3 cube (packing fraction ~0.4 at n =
// 60000 and radius 0.5), in spatially compact order (2.5-unit blocks, front = large z, towards
// the default view 0 camera, first) as the converter's Morton order + PCL meshlets give, so front
// meshlets occlude back ones. Seeded: the same block every run.
inline std::vector<glm::dvec3> dense_block_positions(size_t n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 20.0);
  std::vector<glm::dvec3> pos(n);
  for (auto& p : pos) p = {u(rng), u(rng), u(rng)};
  auto key = [](const glm::dvec3& p) {
    int bx = int(p.x / 2.5), by = int(p.y / 2.5), bz = 7 - int(p.z / 2.5);
    return (bz * 8 + by) * 8 + bx;
  };
  std::sort(pos.begin(), pos.end(), [&](const glm::dvec3& a, const glm::dvec3& b) { return key(a) < key(b); });
  return pos;
}

// `mdstream ARGS` with its output discarded; the exit status (-1 when it did not exit).
inline int run_mdstream_quietly(const std::string& args) {
  const std::string cmd = std::string(MDSTREAM_BIN) + " " + args + " >/dev/null 2>&1";
  const int r = std::system(cmd.c_str());
  return WIFEXITED(r) ? WEXITSTATUS(r) : -1;
}

}  // namespace mds::testing
