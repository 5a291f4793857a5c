#include "vk/commands.h"

#include <algorithm>
#include <memory>

#include "vk/context.h"

namespace mds::vk {

Result<FrameSlot> FrameSlot::create(Context& ctx) {
  FrameSlot s;
  s.device_ = ctx.device();
  VkCommandPoolCreateInfo pinfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pinfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pinfo.queueFamilyIndex = ctx.queue_family();
  VkCommandPool pool = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreateCommandPool(s.device_, &pinfo, nullptr, &pool));
  s.pool_ = UniqueCommandPool(s.device_, pool);
  VkCommandBufferAllocateInfo ainfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ainfo.commandPool = pool;
  ainfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ainfo.commandBufferCount = 1;
  MDS_VK_TRY(vkAllocateCommandBuffers(s.device_, &ainfo, &s.cmd_));
  VkFenceCreateInfo finfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreateFence(s.device_, &finfo, nullptr, &fence));
  s.fence_ = UniqueFence(s.device_, fence);
  return s;
}

Result<VkCommandBuffer> FrameSlot::begin() {
  MDS_TRY(wait());
  MDS_VK_TRY(vkResetCommandPool(device_, pool_, 0));
  VkCommandBufferBeginInfo binfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  binfo.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  MDS_VK_TRY(vkBeginCommandBuffer(cmd_, &binfo));
  return cmd_;
}

Status FrameSlot::submit(VkQueue queue) {
  MDS_VK_TRY(vkEndCommandBuffer(cmd_));
  VkFence f = fence_.get();
  MDS_VK_TRY(vkResetFences(device_, 1, &f));
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd_;
  MDS_VK_TRY(vkQueueSubmit(queue, 1, &submit, f));
  pending_ = true;
  return {};
}

Status FrameSlot::wait() {
  if (!pending_) return {};
  VkFence f = fence_.get();
  MDS_VK_TRY(vkWaitForFences(device_, 1, &f, VK_TRUE, UINT64_MAX));
  pending_ = false;
  return {};
}

void set_viewport_scissor(VkCommandBuffer cmd, uint32_t width, uint32_t height) {
  const VkViewport vp{0.0f, 0.0f, float(width), float(height), 0.0f, 1.0f};
  const VkRect2D sc{{0, 0}, {width, height}};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  vkCmdSetScissor(cmd, 0, 1, &sc);
}

void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  VkMemoryBarrier2 b{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  b.srcStageMask = src_stage;
  b.srcAccessMask = src_access;
  b.dstStageMask = dst_stage;
  b.dstAccessMask = dst_access;
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout old_layout,
                   VkImageLayout new_layout, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                   VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.srcStageMask = src_stage;
  b.srcAccessMask = src_access;
  b.dstStageMask = dst_stage;
  b.dstAccessMask = dst_access;
  b.oldLayout = old_layout;
  b.newLayout = new_layout;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {aspect, 0, 1, 0, 1};
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void DeferredDestroyer::collect(uint64_t completed_frame) {
  std::vector<Entry> keep;
  for (auto& e : pending_) {
    if (e.frame <= completed_frame) {
      e.fn();
    } else {
      keep.push_back(std::move(e));
    }
  }
  pending_ = std::move(keep);
}

void dispatch_rows(VkCommandBuffer cmd, uint32_t groups, uint32_t row) {
  vkCmdDispatch(cmd, std::min(groups, row), (groups + row - 1) / row, 1);
}

}  // namespace mds::vk
