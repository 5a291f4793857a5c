// Renderer::resize through the out-of-core renderer and the in-memory one (window resize,
// dynamic resolution): the cache stays, a resize within the targets' capacity allocates nothing,
// the image returns to the same pixels, and a failed resize refuses frames until the next one.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "streaming_render_fixture.h"

namespace fs = std::filesystem;
using namespace mds;
using namespace mds::render;
using namespace mds::testing::streaming_render;

TEST_F(StreamingRender, ResizeKeepsTheCacheAndReturnsToTheSameImage) {
  // Renderer::resize (window resize, dynamic resolution) rebuilds only the size-dependent
  // resources: the nodes resident before stay resident, and after returning to the full size the
  // converged image equals the one rendered before any resize (and the in-memory render).
  auto reader = store::StoreReader::open(store_path());
  ASSERT_TRUE(reader.ok());
  StreamSettings ss;
  ss.gpu_budget = file_size() / 8;
  auto r = Renderer::create_streaming(*ctx_, *reader.value(), settings(true), ss);
  ASSERT_TRUE(r.ok()) << r.error().message;
  Renderer& rr = *r.value();
  const Camera cam = view(*reader.value(), 2);
  auto before = rr.render(cam);
  ASSERT_TRUE(before.ok()) << before.error().message;
  const CacheStats c0 = rr.stats().cache;
  ASSERT_GT(c0.nodes_resident, 0u);

  ASSERT_TRUE(rr.resize(kW / 2, kH / 3).ok());
  EXPECT_EQ(rr.width(), kW / 2);
  EXPECT_EQ(rr.height(), kH / 3);
  const CacheStats c1 = rr.stats().cache;
  EXPECT_EQ(c1.nodes_resident, c0.nodes_resident) << "resize dropped resident nodes";
  EXPECT_EQ(c1.resident_bytes, c0.resident_bytes);
  EXPECT_EQ(c1.nodes_loaded, c0.nodes_loaded);
  // Moving frames at the reduced size (the view restarts by itself after the resize).
  Camera moved = cam;
  for (int f = 0; f < 6; ++f) {
    moved.eye += 0.01 * (cam.target - cam.eye);
    ASSERT_TRUE(rr.set_view(moved).ok());
    auto rep = rr.step();
    ASSERT_TRUE(rep.ok()) << rep.error().message;
  }
  auto small = rr.read_image();
  ASSERT_TRUE(small.ok());
  EXPECT_EQ(small.value().width, kW / 2);
  EXPECT_EQ(small.value().height, kH / 3);
  EXPECT_LE(rr.stats().cache.gpu_peak_bytes, ss.gpu_budget);

  ASSERT_TRUE(rr.resize(kW, kH).ok());
  RenderStats st;
  auto after = rr.render(cam, &st);
  ASSERT_TRUE(after.ok()) << after.error().message;
  ASSERT_EQ(after.value().width, kW);
  ASSERT_EQ(after.value().height, kH);
  EXPECT_TRUE(st.cull.converged);
  EXPECT_LE(differing_pixels(before.value(), after.value()), size_t(kW * kH / 100));
  Image mem = in_memory(*reader.value(), true, 2);
  EXPECT_LE(differing_pixels(mem.img, after.value()), size_t(kW * kH / 100));
  EXPECT_LE(st.cache.gpu_peak_bytes, st.cache.gpu_budget_bytes);
}

TEST_F(StreamingRender, InMemoryResizeRoundTripIsPixelIdentical) {
  auto q = quick_renderer();
  ASSERT_TRUE(q.ok()) << q.error().message;
  Renderer& r = *q.value().r;
  const Camera cam = q.value().cam;
  auto a = r.render(cam);
  ASSERT_TRUE(a.ok());
  ASSERT_TRUE(r.resize(kW / 4, kH / 4).ok());
  auto small = r.render(cam);
  ASSERT_TRUE(small.ok()) << small.error().message;
  EXPECT_EQ(small.value().width, kW / 4);
  ASSERT_TRUE(r.resize(kW, kH).ok());
  auto b = r.render(cam);
  ASSERT_TRUE(b.ok());
  EXPECT_TRUE(a.value().rgba == b.value().rgba) << differing_pixels(a.value(), b.value()) << " pixels differ";
  EXPECT_FALSE(r.resize(0, kH).ok());
}

TEST_F(StreamingRender, ResizeWithinCapacityAllocatesNothingAndMatchesAFreshRenderer) {
  // The size-dependent targets keep their largest size (vk::ensure_buffer / ensure_image_2d):
  // a resize to a size they hold -- dynamic resolution changes the size every few frames --
  // allocates no GPU memory, and the image at the smaller size equals a renderer created at
  // that size (no stale texel of the larger size takes part). Both pixel routes: the visibility
  // buffer with the accumulation in a buffer (the default here), and the attachments with the
  // accumulation in an image (images kept larger than the frame, read back at its size).
  for (const bool attachments : {false, true}) {
    SCOPED_TRACE(attachments ? "attachments, accumulation image" : "default routes");
    if (attachments) {
      setenv("MDSTREAM_PIXEL_ROUTE", "attachments", 1);
      setenv("MDSTREAM_ACCUM", "image", 1);
    }
    struct Unset {
      ~Unset() {
        unsetenv("MDSTREAM_PIXEL_ROUTE");
        unsetenv("MDSTREAM_ACCUM");
      }
    } unset;
    const RenderSettings rs = quick_settings();
    auto q = quick_renderer(rs);
    ASSERT_TRUE(q.ok()) << q.error().message;
    Renderer& r = *q.value().r;
    const Camera cam = q.value().cam;
    ASSERT_TRUE(r.render(cam).ok());
    const vk::Allocator& alloc = ctx_->allocator();
    const uint32_t sw = kW / 2 + 3, sh = kH / 3 + 1;  // odd sizes: other pyramid levels and strides
    uint64_t before = alloc.allocation_count();
    ASSERT_TRUE(r.resize(sw, sh).ok());
    EXPECT_EQ(alloc.allocation_count(), before) << "a resize to a smaller size allocated";
    RenderStats st;
    auto small = r.render(cam, &st);
    ASSERT_TRUE(small.ok()) << small.error().message;
    EXPECT_EQ(st.visibility_route, !attachments);
    EXPECT_EQ(st.accumulation_buffer, !attachments);
    ASSERT_EQ(small.value().width, sw);
    ASSERT_EQ(small.value().height, sh);

    RenderSettings fs = rs;
    fs.width = sw;
    fs.height = sh;
    auto fresh = quick_renderer(fs);
    ASSERT_TRUE(fresh.ok()) << fresh.error().message;
    auto ref = fresh.value().r->render(cam);
    ASSERT_TRUE(ref.ok());
    EXPECT_TRUE(small.value().rgba == ref.value().rgba) << differing_pixels(small.value(), ref.value()) << " pixels differ";

    // Back to the full size and a size between: still within the capacity.
    before = alloc.allocation_count();
    ASSERT_TRUE(r.resize(kW, kH).ok());
    ASSERT_TRUE(r.resize(kW - 5, kH - 7).ok());
    EXPECT_EQ(alloc.allocation_count(), before) << "a resize within the capacity allocated";
    // Wider than ever before: new targets.
    ASSERT_TRUE(r.resize(kW + 16, kH).ok());
    EXPECT_GT(alloc.allocation_count(), before);
    auto wide = r.render(cam);
    ASSERT_TRUE(wide.ok()) << wide.error().message;
    EXPECT_EQ(wide.value().width, kW + 16);
  }
}

TEST_F(StreamingRender, AFailedResizeRefusesFramesUntilTheNextOne) {
  // A resize whose targets cannot be made (here: the visibility buffer beyond
  // maxStorageBufferRange) fails naming the size, and the renderer then refuses frames and
  // images instead of drawing into released targets; a resize to a size that fits restores it.
  const uint64_t range = ctx_->limits().maxStorageBufferRange;
  const uint32_t w = 16384, h = uint32_t(std::min<uint64_t>(16384, range / 8 / w + 1));
  if (8ull * w * h <= range) GTEST_SKIP() << "no size up to 16384 x 16384 exceeds maxStorageBufferRange " << range;
  auto q = quick_renderer();
  ASSERT_TRUE(q.ok()) << q.error().message;
  Renderer& r = *q.value().r;
  const Camera cam = q.value().cam;
  auto before = r.render(cam);
  ASSERT_TRUE(before.ok());
  if (!r.stats().visibility_route) GTEST_SKIP() << "the attachments route has no buffer to exceed the range";
  Status st = r.resize(w, h);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find(std::to_string(w) + "x" + std::to_string(h)), std::string::npos) << st.error().message;
  ASSERT_TRUE(r.set_view(cam).ok());
  auto step = r.step();
  ASSERT_FALSE(step.ok());
  EXPECT_NE(step.error().message.find("resize"), std::string::npos) << step.error().message;
  EXPECT_FALSE(r.read_image().ok());
  ASSERT_TRUE(r.resize(kW, kH).ok());
  auto after = r.render(cam);
  ASSERT_TRUE(after.ok()) << after.error().message;
  EXPECT_TRUE(before.value().rgba == after.value().rgba) << differing_pixels(before.value(), after.value()) << " pixels differ";
}
