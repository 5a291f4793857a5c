#include "vk/staging.h"

#include <algorithm>
#include <cstring>

#include "vk/context.h"

namespace mds::vk {

Result<StagingRing> StagingRing::create(Context& ctx, VkDeviceSize capacity) {
  StagingRing r;
  r.ctx_ = &ctx;
  MDS_ASSIGN_OR_RETURN(r.ring_, Buffer::create(ctx.allocator(), capacity, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                               MemoryIntent::upload, "staging ring"));
  MDS_ASSIGN_OR_RETURN(r.slot_, FrameSlot::create(ctx));
  return r;
}

Status StagingRing::ensure_recording() {
  if (recording_) return {};
  MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, slot_.begin());
  (void)cmd;
  recording_ = true;
  head_ = 0;
  return {};
}

Status StagingRing::upload(const Buffer& dst, VkDeviceSize offset, std::span<const std::byte> bytes) {
  if (offset + bytes.size() > dst.size())
    return make_error(Errc::internal, "staging upload of {} bytes at offset {} overruns a {}-byte buffer",
                      bytes.size(), offset, dst.size());
  size_t done = 0;
  while (done < bytes.size()) {
    MDS_TRY(ensure_recording());
    VkDeviceSize room = ring_.size() - head_;
    if (room < 16) {
      MDS_TRY(flush());
      continue;
    }
    size_t chunk = std::min<size_t>(room, bytes.size() - done);
    std::memcpy(static_cast<std::byte*>(ring_.mapped()) + head_, bytes.data() + done, chunk);
    VkBufferCopy copy{head_, offset + done, chunk};
    vkCmdCopyBuffer(slot_.cmd(), ring_.get(), dst.get(), 1, &copy);
    head_ = (head_ + chunk + 15) & ~VkDeviceSize(15);
    done += chunk;
    total_ += chunk;
  }
  return {};
}

Status StagingRing::flush() {
  if (!recording_) return {};
  ring_.flush();
  memory_barrier(slot_.cmd(), VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                 VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  MDS_TRY(slot_.submit(ctx_->queue()));
  MDS_TRY(slot_.wait());
  recording_ = false;
  head_ = 0;
  return {};
}

Result<std::vector<std::byte>> read_buffer(Context& ctx, const Buffer& src, VkDeviceSize offset, VkDeviceSize size) {
  return read_buffer(ctx, src.get(), offset, size);
}

Result<std::vector<std::byte>> read_buffer(Context& ctx, VkBuffer src, VkDeviceSize offset, VkDeviceSize size) {
  MDS_ASSIGN_OR_RETURN(Buffer rb, Buffer::create(ctx.allocator(), size, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                 MemoryIntent::readback, "readback buffer"));
  MDS_TRY(ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferCopy copy{offset, 0, size};
    vkCmdCopyBuffer(cmd, src, rb.get(), 1, &copy);
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                   VK_ACCESS_2_HOST_READ_BIT);
  }));
  rb.invalidate();
  std::vector<std::byte> out(size);
  std::memcpy(out.data(), rb.mapped(), size);
  return out;
}

Result<std::vector<std::byte>> read_image(Context& ctx, const Image& image, VkImageLayout layout,
                                          uint32_t texel_bytes, uint32_t width, uint32_t height) {
  if (width == 0 || height == 0) {
    width = image.width();
    height = image.height();
  }
  if (width > image.width() || height > image.height())
    return make_error(Errc::invalid_argument, "read_image: {}x{} texels of a {}x{} image", width, height,
                      image.width(), image.height());
  const VkDeviceSize size = VkDeviceSize(width) * height * texel_bytes;
  MDS_ASSIGN_OR_RETURN(Buffer rb, Buffer::create(ctx.allocator(), size, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                 MemoryIntent::readback, "image readback buffer"));
  MDS_TRY(ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    image_barrier(cmd, image.get(), image.aspect(), layout, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                  VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                  VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferImageCopy region{};
    region.imageSubresource = {image.aspect(), 0, 0, 1};
    region.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, image.get(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, rb.get(), 1, &region);
    image_barrier(cmd, image.get(), image.aspect(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, layout,
                  VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                  VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                   VK_ACCESS_2_HOST_READ_BIT);
  }));
  rb.invalidate();
  std::vector<std::byte> out(size);
  std::memcpy(out.data(), rb.mapped(), size);
  return out;
}

}  // namespace mds::vk
