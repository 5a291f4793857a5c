// Test helpers for the rendering tests: a validated Vulkan context per suite, the renderer's
// image tolerance, and running the CLI.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#include "render/renderer.h"
#include "vk/context.h"

namespace mds::testing {

// A suite sharing one Vulkan context with the Khronos validation layer (where installed); every
// test must end without a validation message.
class VulkanSuite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
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
inline size_t differing_pixels(const render::FrameImage& a, const render::FrameImage& b, float tol = 0.1f) {
  size_t n = 0;
  for (uint32_t y = 0; y < a.height; ++y)
    for (uint32_t x = 0; x < a.width; ++x) {
      const glm::vec4 p = a.at(x, y), q = b.at(x, y);
      if (std::max({std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b)}) > tol) ++n;
    }
  return n;
}

// `mdstream ARGS` with its output discarded; the exit status (-1 when it did not exit).
inline int run_mdstream_quietly(const std::string& args) {
  const std::string cmd = std::string(MDSTREAM_BIN) + " " + args + " >/dev/null 2>&1";
  const int r = std::system(cmd.c_str());
  return WIFEXITED(r) ? WEXITSTATUS(r) : -1;
}

}  // namespace mds::testing
