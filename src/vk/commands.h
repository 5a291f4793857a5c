// Command recording helpers: a per-frame command buffer + fence (FrameSlot), synchronization2
// barriers for buffers/images, and per-frame deferred destruction.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/check.h"

namespace mds::vk {

class Context;

// One command pool, one primary command buffer and one fence: the unit a frame records into.
class FrameSlot {
 public:
  static Result<FrameSlot> create(Context& ctx);
  FrameSlot() = default;
  FrameSlot(FrameSlot&&) = default;
  FrameSlot& operator=(FrameSlot&&) = default;

  // Waits for the previous submission of this slot, resets and begins recording.
  Result<VkCommandBuffer> begin();
  // Ends recording and submits; signals the slot's fence.
  Status submit(VkQueue queue);
  // Blocks until the last submission completed.
  Status wait();
  VkCommandBuffer cmd() const { return cmd_; }

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  UniqueCommandPool pool_;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  UniqueFence fence_;
  bool pending_ = false;
};

// Global memory dependency (synchronization2).
void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);
// vkCmdDispatch of `groups` workgroups in rows of `row` (min(groups, row), ceil(groups / row), 1):
// a long 1D dispatch within the 65535 workgroups per dimension Vulkan guarantees, up to
// row x 65535 (gpu_types.h kDispatchRow; the shader's index: include/dispatch_rows.h).
// Precondition: 1 <= row <= 65535, ceil(groups / row) <= 65535.
void dispatch_rows(VkCommandBuffer cmd, uint32_t groups, uint32_t row);
// Image layout transition + dependency on the whole image.
void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout old_layout,
                   VkImageLayout new_layout, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                   VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);
// Dynamic viewport and scissor covering a width x height target (depth range 0..1).
void set_viewport_scissor(VkCommandBuffer cmd, uint32_t width, uint32_t height);

// Destroys resources once the frame that last used them has completed on the GPU.
// retire(frame, fn): run fn when collect(completed) is called with completed >= frame.
class DeferredDestroyer {
 public:
  DeferredDestroyer() = default;
  DeferredDestroyer(const DeferredDestroyer&) = delete;
  DeferredDestroyer& operator=(const DeferredDestroyer&) = delete;
  ~DeferredDestroyer() { collect(UINT64_MAX); }

  void retire(uint64_t frame, std::function<void()> fn) { pending_.push_back({frame, std::move(fn)}); }
  // Moves a resource in; it is destroyed at collect() time.
  template <class T>
  void retire_object(uint64_t frame, T&& object) {
    auto holder = std::make_shared<std::decay_t<T>>(std::forward<T>(object));
    retire(frame, [holder]() mutable { holder.reset(); });
  }
  void collect(uint64_t completed_frame);
  size_t pending() const { return pending_.size(); }

 private:
  struct Entry {
    uint64_t frame;
    std::function<void()> fn;
  };
  std::vector<Entry> pending_;
};

}  // namespace mds::vk
