#include "vk/memory.h"

#include <algorithm>

namespace mds::vk {

namespace {
const char* intent_name(MemoryIntent i) {
  switch (i) {
    case MemoryIntent::device_local: return "device-local";
    case MemoryIntent::upload: return "upload";
    case MemoryIntent::readback: return "readback";
  }
  return "?";
}
}  // namespace

Allocator::Allocator(VkPhysicalDevice physical, VkDevice device, MemoryBudget budget)
    : device_(device), budget_(budget) {
  vkGetPhysicalDeviceMemoryProperties(physical, &props_);
  uint64_t largest_device = 0, largest_host = 0;
  for (uint32_t h = 0; h < props_.memoryHeapCount; ++h) {
    if (props_.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      largest_device = std::max<uint64_t>(largest_device, props_.memoryHeaps[h].size);
  }
  for (uint32_t t = 0; t < props_.memoryTypeCount; ++t) {
    if (props_.memoryTypes[t].propertyFlags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
      largest_host = std::max<uint64_t>(largest_host, props_.memoryHeaps[props_.memoryTypes[t].heapIndex].size);
  }
  if (budget_.device_local == 0) budget_.device_local = largest_device / 10 * 8;
  if (budget_.host == 0) budget_.host = largest_host / 2;
}

int Allocator::find_type(uint32_t type_bits, MemoryIntent intent) const {
  VkMemoryPropertyFlags required = 0, preferred = 0;
  switch (intent) {
    case MemoryIntent::device_local:
      preferred = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
      break;
    case MemoryIntent::upload:
      required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
      preferred = VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
      break;
    case MemoryIntent::readback:
      required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
      preferred = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
      break;
  }
  int best = -1;
  for (uint32_t t = 0; t < props_.memoryTypeCount; ++t) {
    if (!(type_bits & (1u << t))) continue;
    VkMemoryPropertyFlags f = props_.memoryTypes[t].propertyFlags;
    if ((f & required) != required) continue;
    if ((f & preferred) == preferred) return int(t);
    if (best < 0) best = int(t);
  }
  return best;
}

Result<Allocation> Allocator::allocate(const VkMemoryRequirements& req, MemoryIntent intent, const std::string& what) {
  int type = find_type(req.memoryTypeBits, intent);
  if (type < 0)
    return make_error(Errc::unsupported, "no {} memory type for {} ({} bytes)", intent_name(intent), what, req.size);
  const bool host = intent != MemoryIntent::device_local;
  const uint64_t budget = host ? budget_.host : budget_.device_local;
  const uint64_t in_use = host ? used_[1] + used_[2] : used_[0];
  if (in_use + req.size > budget)
    return make_error(Errc::budget, "GPU memory budget exceeded allocating {} ({} bytes, {} memory): {} of {} bytes in use",
                      what, req.size, intent_name(intent), in_use, budget);
  VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  info.allocationSize = req.size;
  info.memoryTypeIndex = uint32_t(type);
  Allocation a;
  VkResult r = vkAllocateMemory(device_, &info, nullptr, &a.memory);
  if (r != VK_SUCCESS)
    return make_error(Errc::budget, "vkAllocateMemory for {} ({} bytes) failed: {}", what, req.size, vk_result_name(r));
  a.size = req.size;
  a.intent = intent;
  const VkMemoryPropertyFlags f = props_.memoryTypes[type].propertyFlags;
  a.coherent = (f & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
  if (f & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
    r = vkMapMemory(device_, a.memory, 0, VK_WHOLE_SIZE, 0, &a.mapped);
    if (r != VK_SUCCESS) {
      vkFreeMemory(device_, a.memory, nullptr);
      return make_error(Errc::internal, "vkMapMemory for {} failed: {}", what, vk_result_name(r));
    }
  }
  used_[size_t(intent)] += a.size;
  ++allocations_;
  peak_[size_t(intent)] = std::max(peak_[size_t(intent)], used_[size_t(intent)]);
  return a;
}

void Allocator::free(Allocation& a) {
  if (a.memory == VK_NULL_HANDLE) return;
  if (a.mapped) vkUnmapMemory(device_, a.memory);
  vkFreeMemory(device_, a.memory, nullptr);
  used_[size_t(a.intent)] -= a.size;
  a = Allocation{};
}

Result<Buffer> Buffer::create(Allocator& alloc, VkDeviceSize size, VkBufferUsageFlags usage, MemoryIntent intent,
                              const std::string& name) {
  Buffer b;
  b.allocator_ = &alloc;
  b.size_ = std::max<VkDeviceSize>(size, 4);
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = b.size_;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkBuffer raw = VK_NULL_HANDLE;
  VkResult r = vkCreateBuffer(alloc.device(), &info, nullptr, &raw);
  if (r != VK_SUCCESS) return make_error(Errc::internal, "vkCreateBuffer {} ({} bytes): {}", name, size, vk_result_name(r));
  b.buffer_ = UniqueBuffer(alloc.device(), raw);
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(alloc.device(), raw, &req);
  MDS_ASSIGN_OR_RETURN(b.alloc_, alloc.allocate(req, intent, name));
  MDS_VK_TRY(vkBindBufferMemory(alloc.device(), raw, b.alloc_.memory, 0));
  return b;
}

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    reset();
    allocator_ = std::exchange(o.allocator_, nullptr);
    buffer_ = std::move(o.buffer_);
    alloc_ = std::exchange(o.alloc_, Allocation{});
    size_ = std::exchange(o.size_, 0);
  }
  return *this;
}

void Buffer::reset() {
  buffer_.reset();
  if (allocator_) allocator_->free(alloc_);
  size_ = 0;
}

void Buffer::flush() const {
  if (alloc_.coherent || !alloc_.mapped) return;
  VkMappedMemoryRange range{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE, nullptr, alloc_.memory, 0, VK_WHOLE_SIZE};
  vkFlushMappedMemoryRanges(allocator_->device(), 1, &range);
}

void Buffer::invalidate() const {
  if (alloc_.coherent || !alloc_.mapped) return;
  VkMappedMemoryRange range{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE, nullptr, alloc_.memory, 0, VK_WHOLE_SIZE};
  vkInvalidateMappedMemoryRanges(allocator_->device(), 1, &range);
}

Result<Image> Image::create_2d(Allocator& alloc, uint32_t width, uint32_t height, VkFormat format,
                               VkImageUsageFlags usage, VkImageAspectFlags aspect, const std::string& name) {
  Image im;
  im.allocator_ = &alloc;
  im.format_ = format;
  im.aspect_ = aspect;
  im.width_ = width;
  im.height_ = height;
  VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width, height, 1};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImage raw = VK_NULL_HANDLE;
  VkResult r = vkCreateImage(alloc.device(), &info, nullptr, &raw);
  if (r != VK_SUCCESS)
    return make_error(Errc::internal, "vkCreateImage {} ({}x{}): {}", name, width, height, vk_result_name(r));
  im.image_ = UniqueImage(alloc.device(), raw);
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(alloc.device(), raw, &req);
  MDS_ASSIGN_OR_RETURN(im.alloc_, alloc.allocate(req, MemoryIntent::device_local, name));
  MDS_VK_TRY(vkBindImageMemory(alloc.device(), raw, im.alloc_.memory, 0));
  VkImageViewCreateInfo vinfo{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vinfo.image = raw;
  vinfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vinfo.format = format;
  vinfo.subresourceRange = {aspect, 0, 1, 0, 1};
  VkImageView view = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreateImageView(alloc.device(), &vinfo, nullptr, &view));
  im.view_ = UniqueImageView(alloc.device(), view);
  return im;
}

Image& Image::operator=(Image&& o) noexcept {
  if (this != &o) {
    reset();
    allocator_ = std::exchange(o.allocator_, nullptr);
    image_ = std::move(o.image_);
    view_ = std::move(o.view_);
    alloc_ = std::exchange(o.alloc_, Allocation{});
    format_ = o.format_;
    aspect_ = o.aspect_;
    width_ = o.width_;
    height_ = o.height_;
  }
  return *this;
}

void Image::reset() {
  view_.reset();
  image_.reset();
  if (allocator_) allocator_->free(alloc_);
}

Result<bool> ensure_buffer(Buffer& b, Allocator& alloc, VkDeviceSize size, VkBufferUsageFlags usage,
                           MemoryIntent intent, const std::string& name) {
  if (b.valid() && b.size() >= size) return false;
  b.reset();  // before the new one: the budget counts one of them
  MDS_ASSIGN_OR_RETURN(b, Buffer::create(alloc, size, usage, intent, name));
  return true;
}

Result<bool> ensure_image_2d(Image& im, Allocator& alloc, uint32_t width, uint32_t height, VkFormat format,
                             VkImageUsageFlags usage, VkImageAspectFlags aspect, const std::string& name) {
  if (im.get() != VK_NULL_HANDLE && im.width() >= width && im.height() >= height) return false;
  // A new one holds both the old extent and the new one (a resize that grows one side only).
  const uint32_t w = std::max(width, im.get() != VK_NULL_HANDLE ? im.width() : 0u);
  const uint32_t h = std::max(height, im.get() != VK_NULL_HANDLE ? im.height() : 0u);
  im.reset();
  MDS_ASSIGN_OR_RETURN(im, Image::create_2d(alloc, w, h, format, usage, aspect, name));
  return true;
}

}  // namespace mds::vk
