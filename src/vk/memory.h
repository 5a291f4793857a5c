// GPU memory by intent, with all budget accounting in one place.
//
// Allocator picks a memory type for an intent (device-local pool, host-visible upload/staging,
// host-cached readback), counts the bytes of every live allocation per intent against a budget
// and refuses (Errc::budget, naming the resource) when a request would exceed it. Allocations are
// dedicated (one VkDeviceMemory per buffer/image): the renderer owns a handful of large buffers,
// far below maxMemoryAllocationCount, so sub-allocation would buy nothing yet.
// Buffer and Image are RAII owners of a resource plus its memory.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/check.h"

namespace mds::vk {

enum class MemoryIntent : uint32_t {
  device_local = 0,  // GPU-resident data (scene buffers, render targets)
  upload = 1,        // host-visible, written by the CPU (staging ring, uniforms)
  readback = 2,      // host-visible, read by the CPU (image/buffer readback)
};
inline constexpr size_t kIntentCount = 3;

struct Allocation {
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // persistently mapped for host intents
  bool coherent = true;
  MemoryIntent intent = MemoryIntent::device_local;
};

struct MemoryBudget {
  uint64_t device_local = 0;  // 0: 80 % of the largest device-local heap
  uint64_t host = 0;          // upload + readback; 0: 50 % of the largest host-visible heap
};

class Allocator {
 public:
  Allocator(VkPhysicalDevice physical, VkDevice device, MemoryBudget budget);
  Allocator(const Allocator&) = delete;
  Allocator& operator=(const Allocator&) = delete;

  Result<Allocation> allocate(const VkMemoryRequirements& req, MemoryIntent intent, const std::string& what);
  void free(Allocation& a);

  uint64_t used(MemoryIntent i) const { return used_[size_t(i)]; }
  uint64_t peak(MemoryIntent i) const { return peak_[size_t(i)]; }
  // vkAllocateMemory calls so far (tests: a resize within the targets' capacity makes none).
  uint64_t allocation_count() const { return allocations_; }
  uint64_t device_budget() const { return budget_.device_local; }
  uint64_t host_budget() const { return budget_.host; }
  VkDevice device() const { return device_; }

 private:
  int find_type(uint32_t type_bits, MemoryIntent intent) const;

  VkDevice device_;
  VkPhysicalDeviceMemoryProperties props_{};
  MemoryBudget budget_;
  std::array<uint64_t, kIntentCount> used_{};
  std::array<uint64_t, kIntentCount> peak_{};
  uint64_t allocations_ = 0;
};

class Buffer {
 public:
  Buffer() = default;
  static Result<Buffer> create(Allocator& alloc, VkDeviceSize size, VkBufferUsageFlags usage, MemoryIntent intent,
                               const std::string& name);
  ~Buffer() { reset(); }
  Buffer(Buffer&& o) noexcept { *this = std::move(o); }
  Buffer& operator=(Buffer&& o) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  void reset();
  VkBuffer get() const { return buffer_.get(); }
  VkDeviceSize size() const { return size_; }
  void* mapped() const { return alloc_.mapped; }
  // For non-coherent host memory: make CPU writes visible / GPU writes readable.
  void flush() const;
  void invalidate() const;
  bool valid() const { return buffer_.get() != VK_NULL_HANDLE; }

 private:
  Allocator* allocator_ = nullptr;
  UniqueBuffer buffer_;
  Allocation alloc_;
  VkDeviceSize size_ = 0;
};

class Image {
 public:
  Image() = default;
  static Result<Image> create_2d(Allocator& alloc, uint32_t width, uint32_t height, VkFormat format,
                                 VkImageUsageFlags usage, VkImageAspectFlags aspect, const std::string& name);
  ~Image() { reset(); }
  Image(Image&& o) noexcept { *this = std::move(o); }
  Image& operator=(Image&& o) noexcept;
  Image(const Image&) = delete;
  Image& operator=(const Image&) = delete;

  void reset();
  VkImage get() const { return image_.get(); }
  VkImageView view() const { return view_.get(); }
  VkFormat format() const { return format_; }
  VkImageAspectFlags aspect() const { return aspect_; }
  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }

 private:
  Allocator* allocator_ = nullptr;
  UniqueImage image_;
  UniqueImageView view_;
  Allocation alloc_;
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  VkImageAspectFlags aspect_ = 0;
  uint32_t width_ = 0, height_ = 0;
};

// Size-dependent resources (render targets, per-pixel buffers) kept at the largest size asked
// for: a resize to a size they already hold (dynamic resolution, a smaller window) keeps them
// and allocates nothing; users index them by the logical size, not the resource's. On the
// H200 a resize that replaced the targets cost 3-4.3 ms of host time (vkAllocateMemory and
// vkFreeMemory of a dozen resources), in 40 % of the dynamic-resolution fly-throughs' frames
// (docs/rendering.md, "Dynamic resolution"). `usage`, `intent` and `format` must be the same at
// every call for one resource (they are not compared). Returns true when a new one was made.
Result<bool> ensure_buffer(Buffer& b, Allocator& alloc, VkDeviceSize size, VkBufferUsageFlags usage,
                           MemoryIntent intent, const std::string& name);
Result<bool> ensure_image_2d(Image& im, Allocator& alloc, uint32_t width, uint32_t height, VkFormat format,
                             VkImageUsageFlags usage, VkImageAspectFlags aspect, const std::string& name);

}  // namespace mds::vk
