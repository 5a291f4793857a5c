// Vulkan foundation on the machine's real device (lavapipe here): context creation, memory
// budget accounting, staging upload / readback round trip, a compute dispatch with a
// specialization constant and push constants, timestamps. Runs with the Khronos validation
// layer when it is installed and asserts that it reported nothing.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "gpu_types.h"
#include "vk/commands.h"
#include "vk/context.h"
#include "vk/embedded_shaders.h"
#include "vk/pipeline.h"
#include "vk/staging.h"
#include "vk/timestamps.h"

using namespace mds;
using namespace mds::vk;

namespace {

std::unique_ptr<Context> make_context(MemoryBudget budget = {}) {
  ContextOptions o;
  o.validation = true;  // used when the layer is installed
  o.budget = budget;
  auto c = Context::create(o);
  EXPECT_TRUE(c.ok()) << (c.ok() ? "" : c.error().message);
  return c.ok() ? std::move(c).value() : nullptr;
}

}  // namespace

TEST(VkContext, CreatesDeviceAndQueue) {
  auto ctx = make_context();
  ASSERT_TRUE(ctx);
  EXPECT_NE(ctx->device(), VK_NULL_HANDLE);
  EXPECT_NE(ctx->queue(), VK_NULL_HANDLE);
  EXPECT_FALSE(ctx->info().name.empty());
  EXPECT_GE(ctx->properties().apiVersion, VK_API_VERSION_1_3);
  auto devices = Context::enumerate();
  ASSERT_TRUE(devices.ok());
  ASSERT_FALSE(devices->empty());
  EXPECT_EQ((*devices)[ctx->info().index].name, ctx->info().name);
  EXPECT_EQ(ctx->validation_messages(), 0u);
}

TEST(VkContext, RejectsDeviceIndexOutOfRange) {
  auto devices = Context::enumerate();
  ASSERT_TRUE(devices.ok());
  ContextOptions o;
  o.device_index = int(devices->size());
  auto c = Context::create(o);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, Errc::invalid_argument);
  EXPECT_NE(c.error().message.find("--device"), std::string::npos);
}

TEST(VkContext, ExplicitDeviceIndexSelectsThatDevice) {
  auto devices = Context::enumerate();
  ASSERT_TRUE(devices.ok());
  for (const auto& d : *devices) {
    if (!d.usable) continue;
    ContextOptions o;
    o.device_index = int(d.index);
    auto c = Context::create(o);
    ASSERT_TRUE(c.ok()) << c.error().message;
    EXPECT_EQ((*c)->info().name, d.name);
  }
}

TEST(VkContext, StagingRoundTripAcrossRingWraps) {
  auto ctx = make_context();
  ASSERT_TRUE(ctx);
  // 300 KiB through a 64 KiB ring: several submissions, unaligned offsets.
  std::vector<std::byte> data(300 * 1024 + 13);
  std::mt19937 rng(42);
  for (auto& b : data) b = std::byte(rng() & 0xff);
  auto dst = Buffer::create(ctx->allocator(), data.size() + 7,
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                            MemoryIntent::device_local, "test buffer");
  ASSERT_TRUE(dst.ok()) << dst.error().message;
  auto ring = StagingRing::create(*ctx, 64 * 1024);
  ASSERT_TRUE(ring.ok()) << ring.error().message;
  ASSERT_TRUE(ring->upload(*dst, 7, data).ok());
  ASSERT_TRUE(ring->flush().ok());
  EXPECT_EQ(ring->bytes_uploaded(), data.size());
  auto back = read_buffer(*ctx, *dst, 7, data.size());
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(std::memcmp(back->data(), data.data(), data.size()), 0);
  // Overrunning the destination is refused, not silently clipped.
  EXPECT_FALSE(ring->upload(*dst, 8, data).ok());
  EXPECT_EQ(ctx->validation_messages(), 0u);
}

TEST(VkContext, AllocatorEnforcesBudgetAndAccounts) {
  MemoryBudget budget;
  budget.device_local = 1 << 20;
  auto ctx = make_context(budget);
  ASSERT_TRUE(ctx);
  auto& alloc = ctx->allocator();
  const uint64_t before = alloc.used(MemoryIntent::device_local);
  {
    auto a = Buffer::create(alloc, 256 * 1024, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryIntent::device_local, "a");
    ASSERT_TRUE(a.ok());
    EXPECT_GE(alloc.used(MemoryIntent::device_local), before + 256 * 1024);
    auto big = Buffer::create(alloc, 2 << 20, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryIntent::device_local,
                              "too big buffer");
    ASSERT_FALSE(big.ok());
    EXPECT_EQ(big.error().code, Errc::budget);
    EXPECT_NE(big.error().message.find("too big buffer"), std::string::npos);
  }
  EXPECT_EQ(alloc.used(MemoryIntent::device_local), before);  // freed on destruction
}

TEST(VkContext, ComputeDispatchWithSpecConstantAndTimestamps) {
  auto ctx = make_context();
  ASSERT_TRUE(ctx);
  ASSERT_FALSE(find_shader("test_saxpy.comp").empty());
  const uint32_t n = 1000;
  const float a = 2.5f;
  std::vector<float> x(n), y(n);
  for (uint32_t i = 0; i < n; ++i) {
    x[i] = float(i) * 0.5f - 17.0f;
    y[i] = float(i % 7) - 3.0f;
  }
  const VkBufferUsageFlags usage =
      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  auto bx = Buffer::create(ctx->allocator(), n * 4, usage, MemoryIntent::device_local, "x");
  auto by = Buffer::create(ctx->allocator(), n * 4, usage, MemoryIntent::device_local, "y");
  ASSERT_TRUE(bx.ok() && by.ok());
  auto ring = StagingRing::create(*ctx);
  ASSERT_TRUE(ring.ok());
  ASSERT_TRUE(ring->upload_span(*bx, 0, std::span<const float>(x)).ok());
  ASSERT_TRUE(ring->upload_span(*by, 0, std::span<const float>(y)).ok());
  ASSERT_TRUE(ring->flush().ok());

  auto set = DescriptorSet::create(
      ctx->device(), {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr},
                      {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr}});
  ASSERT_TRUE(set.ok());
  set->write_buffer(0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, bx->get());
  set->write_buffer(1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, by->get());
  auto layout = create_pipeline_layout(ctx->device(), set->layout(), 4);
  ASSERT_TRUE(layout.ok());
  SpecConstants spec;
  spec.add(0, a);
  auto pipe = create_compute_pipeline(ctx->device(), *layout, "test_saxpy.comp", &spec);
  ASSERT_TRUE(pipe.ok()) << pipe.error().message;
  auto ts = TimestampPool::create(*ctx);
  ASSERT_TRUE(ts.ok());
  auto slot = FrameSlot::create(*ctx);
  ASSERT_TRUE(slot.ok());
  auto cmd = slot->begin();
  ASSERT_TRUE(cmd.ok());
  ts->reset(*cmd);
  ts->begin(*cmd, "saxpy");
  VkDescriptorSet ds = set->set();
  vkCmdBindPipeline(*cmd, VK_PIPELINE_BIND_POINT_COMPUTE, *pipe);
  vkCmdBindDescriptorSets(*cmd, VK_PIPELINE_BIND_POINT_COMPUTE, *layout, 0, 1, &ds, 0, nullptr);
  vkCmdPushConstants(*cmd, *layout, VK_SHADER_STAGE_ALL, 0, 4, &n);
  vkCmdDispatch(*cmd, (n + 63) / 64, 1, 1);
  ts->end(*cmd);
  ASSERT_TRUE(slot->submit(ctx->queue()).ok());
  ASSERT_TRUE(slot->wait().ok());
  ASSERT_TRUE(ts->collect().ok());
  if (ts->enabled()) {
    ASSERT_EQ(ts->samples().count("saxpy"), 1u);
    EXPECT_EQ(ts->samples().at("saxpy").size(), 1u);
    EXPECT_GE(ts->samples().at("saxpy")[0], 0.0);
  }
  auto back = read_buffer(*ctx, *by, 0, n * 4);
  ASSERT_TRUE(back.ok());
  std::vector<float> got(n);
  std::memcpy(got.data(), back->data(), n * 4);
  for (uint32_t i = 0; i < n; ++i) ASSERT_FLOAT_EQ(got[i], a * x[i] + y[i]) << "element " << i;
  EXPECT_EQ(ctx->validation_messages(), 0u);
}

// vk::dispatch_rows + mds_flat_id (include/dispatch_rows.h): a long 1D dispatch in rows of
// workgroups reaches every index below n exactly once, whatever the row width (the shader reads
// it from gl_NumWorkGroups.x): rows of kDispatchRow (64), of 7, and a single row.
TEST(VkContext, DispatchRowsReachEveryIndexOnce) {
  auto ctx = make_context();
  ASSERT_TRUE(ctx);
  const uint32_t n = 64 * 64 * 3 + 17;  // 193 workgroups of 64: 4 rows of 64, the last one partial
  const uint32_t groups = (n + 63) / 64;
  const VkBufferUsageFlags usage =
      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  auto set = DescriptorSet::create(ctx->device(), {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_ALL, nullptr}});
  ASSERT_TRUE(set.ok());
  auto layout = create_pipeline_layout(ctx->device(), set->layout(), 4);
  ASSERT_TRUE(layout.ok());
  auto pipe = create_compute_pipeline(ctx->device(), *layout, "test_flat_id.comp");
  ASSERT_TRUE(pipe.ok()) << pipe.error().message;
  for (const uint32_t row : {gpu::kDispatchRow, 7u, groups}) {
    SCOPED_TRACE(::testing::Message() << "row " << row);
    auto buf = Buffer::create(ctx->allocator(), (n + 64) * 4, usage, MemoryIntent::device_local, "v");
    ASSERT_TRUE(buf.ok());
    set->write_buffer(0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, buf->get());
    auto slot = FrameSlot::create(*ctx);
    ASSERT_TRUE(slot.ok());
    auto cmd = slot->begin();
    ASSERT_TRUE(cmd.ok());
    vkCmdFillBuffer(*cmd, buf->get(), 0, VK_WHOLE_SIZE, 0u);
    memory_barrier(*cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                   VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    VkDescriptorSet ds = set->set();
    vkCmdBindPipeline(*cmd, VK_PIPELINE_BIND_POINT_COMPUTE, *pipe);
    vkCmdBindDescriptorSets(*cmd, VK_PIPELINE_BIND_POINT_COMPUTE, *layout, 0, 1, &ds, 0, nullptr);
    vkCmdPushConstants(*cmd, *layout, VK_SHADER_STAGE_ALL, 0, 4, &n);
    dispatch_rows(*cmd, groups, row);
    ASSERT_TRUE(slot->submit(ctx->queue()).ok());
    ASSERT_TRUE(slot->wait().ok());
    auto back = read_buffer(*ctx, *buf, 0, (n + 64) * 4);
    ASSERT_TRUE(back.ok());
    std::vector<uint32_t> v(n + 64);
    std::memcpy(v.data(), back->data(), v.size() * 4);
    for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(v[i], i + 1) << "index " << i;
    for (uint32_t i = n; i < n + 64; ++i) ASSERT_EQ(v[i], 0u) << "index " << i << " past n";
  }
  EXPECT_EQ(ctx->validation_messages(), 0u);
}

TEST(VkContext, DeferredDestroyerRunsOnlyCompletedFrames) {
  DeferredDestroyer d;
  std::vector<int> ran;
  d.retire(1, [&] { ran.push_back(1); });
  d.retire(3, [&] { ran.push_back(3); });
  d.collect(2);
  EXPECT_EQ(ran, std::vector<int>({1}));
  EXPECT_EQ(d.pending(), 1u);
  d.collect(3);
  EXPECT_EQ(ran, std::vector<int>({1, 3}));
}
