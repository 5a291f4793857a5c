// Host <-> device transfers. StagingRing: a persistently mapped host-visible (upload intent)
// ring through which data reaches device-local buffers; copies are batched into one command
// buffer and submitted when the ring is full or on flush(). Readback: copies a buffer range or a
// whole image into a readback-intent buffer and returns the bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/commands.h"
#include "vk/memory.h"

namespace mds::vk {

class Context;

class StagingRing {
 public:
  static Result<StagingRing> create(Context& ctx, VkDeviceSize capacity = 32ull << 20);
  StagingRing() = default;
  StagingRing(StagingRing&&) = default;
  StagingRing& operator=(StagingRing&&) = default;

  // Queues a copy of `bytes` to dst[offset...]; may submit and wait when the ring is full.
  Status upload(const Buffer& dst, VkDeviceSize offset, std::span<const std::byte> bytes);
  template <class T>
  Status upload_span(const Buffer& dst, VkDeviceSize offset, std::span<const T> items) {
    return upload(dst, offset, std::as_bytes(items));
  }
  // Submits queued copies and waits; afterwards the data is visible to all later GPU work.
  Status flush();
  uint64_t bytes_uploaded() const { return total_; }

 private:
  Status ensure_recording();

  Context* ctx_ = nullptr;
  Buffer ring_;
  FrameSlot slot_;
  VkDeviceSize head_ = 0;
  bool recording_ = false;
  uint64_t total_ = 0;
};

// Reads `size` bytes of `src` at `offset` (src needs TRANSFER_SRC usage). Waits for the GPU.
Result<std::vector<std::byte>> read_buffer(Context& ctx, const Buffer& src, VkDeviceSize offset, VkDeviceSize size);
Result<std::vector<std::byte>> read_buffer(Context& ctx, VkBuffer src, VkDeviceSize offset, VkDeviceSize size);
// Reads the top-left width x height texels (0, 0: the whole image) of a single-aspect 2D image
// currently in `layout` (needs TRANSFER_SRC usage; a target kept at a larger capacity, see
// ensure_image_2d, is read at its logical size); the image is returned to `layout`. Tightly
// packed rows, texel size from `texel_bytes`. Precondition: the extent lies inside the image.
Result<std::vector<std::byte>> read_image(Context& ctx, const Image& image, VkImageLayout layout,
                                          uint32_t texel_bytes, uint32_t width = 0, uint32_t height = 0);

}  // namespace mds::vk
