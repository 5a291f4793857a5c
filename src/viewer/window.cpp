#include "viewer/window.h"

#include <algorithm>
#include <cstring>
#include <mutex>

#include <vulkan/vulkan.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "vk/check.h"
#include "overlay/canvas.h"

namespace mds::viewer {

namespace {

std::mutex g_error_mutex;
std::string g_last_error;

void glfw_error(int code, const char* description) {
  std::lock_guard lock(g_error_mutex);
  g_last_error = std::string(description ? description : "?") + " (GLFW error " + std::to_string(code) + ")";
}

std::string last_glfw_error() {
  std::lock_guard lock(g_error_mutex);
  return g_last_error.empty() ? "unknown GLFW error" : g_last_error;
}

}  // namespace

// ---------------------------------------------------------------------------------------- Window

Result<std::unique_ptr<Window>> Window::create(uint32_t width, uint32_t height, const std::string& title) {
  glfwSetErrorCallback(glfw_error);
  if (!glfwInit())
    return make_error(Errc::unsupported,
                      "cannot open a window: {} (is DISPLAY set? without a display server, run under Xvfb, e.g. "
                      "xvfb-run mdstream view ...)",
                      last_glfw_error());
  std::unique_ptr<Window> w(new Window());
  if (!glfwVulkanSupported()) {
    glfwTerminate();
    return make_error(Errc::unsupported, "cannot open a window: GLFW finds no Vulkan loader/ICD with window-system support");
  }
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
  w->window_ = glfwCreateWindow(int(width), int(height), title.c_str(), nullptr, nullptr);
  if (!w->window_) {
    glfwTerminate();
    return make_error(Errc::unsupported, "cannot create a {}x{} window: {}", width, height, last_glfw_error());
  }
  return w;
}

Window::~Window() {
  if (window_) glfwDestroyWindow(window_);
  glfwTerminate();
}

bool Window::should_close() const { return glfwWindowShouldClose(window_); }

void Window::framebuffer_size(uint32_t& width, uint32_t& height) const {
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  width = uint32_t(std::max(w, 0));
  height = uint32_t(std::max(h, 0));
}

void Window::set_title(const std::string& title) { glfwSetWindowTitle(window_, title.c_str()); }

void Window::add_to_context_options(vk::ContextOptions& options) const {
  uint32_t n = 0;
  const char** exts = glfwGetRequiredInstanceExtensions(&n);
  for (uint32_t i = 0; i < n; ++i) options.instance_extensions.emplace_back(exts[i]);
  options.device_extensions.emplace_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  GLFWwindow* win = window_;
  options.make_surface = [win](VkInstance instance) -> Result<VkSurfaceKHR> {
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    const VkResult r = glfwCreateWindowSurface(instance, win, nullptr, &surface);
    if (r != VK_SUCCESS) return make_error(Errc::unsupported, "cannot create a Vulkan surface for the window: {} ({})",
                                           vk::vk_result_name(r), last_glfw_error());
    return surface;
  };
}

// ------------------------------------------------------------------------------------- Swapchain

Result<std::unique_ptr<Swapchain>> Swapchain::create(vk::Context& ctx, uint32_t width, uint32_t height) {
  if (ctx.surface() == VK_NULL_HANDLE) return make_error(Errc::internal, "Swapchain: the context has no surface");
  std::unique_ptr<Swapchain> s(new Swapchain());
  s->ctx_ = &ctx;
  VkDevice dev = ctx.device();
  VkCommandPoolCreateInfo pinfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pinfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pinfo.queueFamilyIndex = ctx.queue_family();
  MDS_VK_TRY(vkCreateCommandPool(dev, &pinfo, nullptr, &s->pool_));
  VkCommandBufferAllocateInfo ainfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ainfo.commandPool = s->pool_;
  ainfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ainfo.commandBufferCount = 1;
  MDS_VK_TRY(vkAllocateCommandBuffers(dev, &ainfo, &s->cmd_));
  VkFenceCreateInfo finfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  finfo.flags = VK_FENCE_CREATE_SIGNALED_BIT;
  MDS_VK_TRY(vkCreateFence(dev, &finfo, nullptr, &s->fence_));
  VkSemaphoreCreateInfo sinfo{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  MDS_VK_TRY(vkCreateSemaphore(dev, &sinfo, nullptr, &s->acquired_));
  MDS_TRY(s->build(width, height));
  return s;
}

Swapchain::~Swapchain() {
  if (!ctx_) return;
  VkDevice dev = ctx_->device();
  vkDeviceWaitIdle(dev);
  destroy_swapchain();
  if (acquired_) vkDestroySemaphore(dev, acquired_, nullptr);
  if (fence_) vkDestroyFence(dev, fence_, nullptr);
  if (pool_) vkDestroyCommandPool(dev, pool_, nullptr);
}

void Swapchain::destroy_swapchain() {
  VkDevice dev = ctx_->device();
  for (VkSemaphore s : rendered_) vkDestroySemaphore(dev, s, nullptr);
  rendered_.clear();
  images_.clear();
  if (swapchain_) vkDestroySwapchainKHR(dev, swapchain_, nullptr);
  swapchain_ = VK_NULL_HANDLE;
}

Status Swapchain::resize(uint32_t width, uint32_t height) {
  MDS_VK_TRY(vkDeviceWaitIdle(ctx_->device()));
  return build(width, height);
}

Status Swapchain::build(uint32_t width, uint32_t height) {
  VkPhysicalDevice pd = ctx_->physical();
  VkSurfaceKHR surface = ctx_->surface();
  VkDevice dev = ctx_->device();
  VkSurfaceCapabilitiesKHR caps;
  MDS_VK_TRY(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, surface, &caps));
  if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT))
    return make_error(Errc::unsupported, "the window's swapchain images cannot be transfer destinations");

  uint32_t nf = 0;
  MDS_VK_TRY(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface, &nf, nullptr));
  std::vector<VkSurfaceFormatKHR> formats(nf);
  MDS_VK_TRY(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface, &nf, formats.data()));
  // The CPU writes sRGB-encoded bytes and the copy does not convert: an *_UNORM image displays
  // them as they are; an *_SRGB image stores the same bytes as sRGB-encoded values (also right).
  const VkFormat wanted[] = {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM, VK_FORMAT_B8G8R8A8_SRGB,
                             VK_FORMAT_R8G8B8A8_SRGB};
  VkSurfaceFormatKHR chosen{VK_FORMAT_UNDEFINED, VK_COLOR_SPACE_SRGB_NONLINEAR_KHR};
  for (VkFormat f : wanted) {
    for (const auto& sf : formats)
      if (sf.format == f && sf.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) {
        chosen = sf;
        break;
      }
    if (chosen.format != VK_FORMAT_UNDEFINED) break;
  }
  if (chosen.format == VK_FORMAT_UNDEFINED)
    return make_error(Errc::unsupported, "the window offers no 8-bit RGBA/BGRA sRGB swapchain format");
  format_ = chosen.format;
  bgra_ = format_ == VK_FORMAT_B8G8R8A8_UNORM || format_ == VK_FORMAT_B8G8R8A8_SRGB;

  uint32_t npm = 0;
  MDS_VK_TRY(vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface, &npm, nullptr));
  std::vector<VkPresentModeKHR> modes(npm);
  MDS_VK_TRY(vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface, &npm, modes.data()));
  // Frame times measure the renderer, not the display: no vsync when the driver allows.
  VkPresentModeKHR mode = VK_PRESENT_MODE_FIFO_KHR;
  for (VkPresentModeKHR m : {VK_PRESENT_MODE_MAILBOX_KHR, VK_PRESENT_MODE_IMMEDIATE_KHR})
    if (std::find(modes.begin(), modes.end(), m) != modes.end()) {
      mode = m;
      break;
    }

  VkExtent2D extent = caps.currentExtent;
  if (extent.width == 0xFFFFFFFFu) {
    extent.width = std::clamp(width, caps.minImageExtent.width, caps.maxImageExtent.width);
    extent.height = std::clamp(height, caps.minImageExtent.height, caps.maxImageExtent.height);
  }
  if (extent.width == 0 || extent.height == 0) return {};  // minimised: keep the old one
  uint32_t count = caps.minImageCount + 1;
  if (caps.maxImageCount > 0) count = std::min(count, caps.maxImageCount);

  VkSwapchainCreateInfoKHR info{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  info.surface = surface;
  info.minImageCount = count;
  info.imageFormat = chosen.format;
  info.imageColorSpace = chosen.colorSpace;
  info.imageExtent = extent;
  info.imageArrayLayers = 1;
  info.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.preTransform = caps.currentTransform;
  info.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                            ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                            : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
  info.presentMode = mode;
  info.clipped = VK_TRUE;
  info.oldSwapchain = swapchain_;
  VkSwapchainKHR fresh = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreateSwapchainKHR(dev, &info, nullptr, &fresh));
  destroy_swapchain();
  swapchain_ = fresh;
  extent_ = extent;
  uint32_t n = 0;
  MDS_VK_TRY(vkGetSwapchainImagesKHR(dev, swapchain_, &n, nullptr));
  images_.resize(n);
  MDS_VK_TRY(vkGetSwapchainImagesKHR(dev, swapchain_, &n, images_.data()));
  VkSemaphoreCreateInfo sinfo{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  rendered_.resize(n, VK_NULL_HANDLE);
  for (auto& s : rendered_) MDS_VK_TRY(vkCreateSemaphore(dev, &sinfo, nullptr, &s));
  return {};
}

Result<bool> Swapchain::present(const Canvas& canvas) {
  if (swapchain_ == VK_NULL_HANDLE) return false;
  VkDevice dev = ctx_->device();
  MDS_VK_TRY(vkWaitForFences(dev, 1, &fence_, VK_TRUE, UINT64_MAX));
  uint32_t index = 0;
  VkResult r = vkAcquireNextImageKHR(dev, swapchain_, UINT64_MAX, acquired_, VK_NULL_HANDLE, &index);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) return false;
  if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) return vk::vk_error(r, "vkAcquireNextImageKHR");

  // Staging: the canvas in the swapchain's channel order.
  const uint32_t cw = std::min(canvas.width(), extent_.width), ch = std::min(canvas.height(), extent_.height);
  const VkDeviceSize bytes = VkDeviceSize(std::max(cw, 1u)) * std::max(ch, 1u) * 4;
  if (!staging_.valid() || staging_.size() < bytes) {
    staging_ = {};
    MDS_ASSIGN_OR_RETURN(staging_, vk::Buffer::create(ctx_->allocator(), bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                                      vk::MemoryIntent::upload, "viewer staging"));
  }
  auto* dst = static_cast<uint8_t*>(staging_.mapped());
  const uint8_t* src = canvas.data();
  for (uint32_t y = 0; y < ch; ++y) {
    const uint8_t* s = src + size_t(y) * canvas.width() * 4;
    uint8_t* d = dst + size_t(y) * cw * 4;
    if (bgra_) {
      for (uint32_t x = 0; x < cw; ++x) {
        d[4 * x + 0] = s[4 * x + 2];
        d[4 * x + 1] = s[4 * x + 1];
        d[4 * x + 2] = s[4 * x + 0];
        d[4 * x + 3] = 255;
      }
    } else {
      std::memcpy(d, s, size_t(cw) * 4);
    }
  }
  staging_.flush();

  MDS_VK_TRY(vkResetCommandBuffer(cmd_, 0));
  VkCommandBufferBeginInfo binfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  binfo.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  MDS_VK_TRY(vkBeginCommandBuffer(cmd_, &binfo));
  VkImage image = images_[index];
  VkImageMemoryBarrier to_dst{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  to_dst.srcAccessMask = 0;
  to_dst.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  to_dst.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;  // every pixel is rewritten
  to_dst.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  to_dst.srcQueueFamilyIndex = to_dst.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_dst.image = image;
  to_dst.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                       nullptr, 1, &to_dst);
  if (cw < extent_.width || ch < extent_.height) {
    VkClearColorValue black{};
    vkCmdClearColorImage(cmd_, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &black, 1, &to_dst.subresourceRange);
    VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &mb, 0, nullptr,
                         0, nullptr);
  }
  if (cw > 0 && ch > 0) {
    VkBufferImageCopy region{};
    region.bufferRowLength = cw;
    region.bufferImageHeight = ch;
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {cw, ch, 1};
    vkCmdCopyBufferToImage(cmd_, staging_.get(), image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  }
  VkImageMemoryBarrier to_present = to_dst;
  to_present.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  to_present.dstAccessMask = 0;
  to_present.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  to_present.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0,
                       nullptr, 1, &to_present);
  MDS_VK_TRY(vkEndCommandBuffer(cmd_));

  const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.waitSemaphoreCount = 1;
  submit.pWaitSemaphores = &acquired_;
  submit.pWaitDstStageMask = &wait_stage;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd_;
  submit.signalSemaphoreCount = 1;
  submit.pSignalSemaphores = &rendered_[index];
  MDS_VK_TRY(vkResetFences(dev, 1, &fence_));
  MDS_VK_TRY(vkQueueSubmit(ctx_->queue(), 1, &submit, fence_));

  VkPresentInfoKHR pinfo{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
  pinfo.waitSemaphoreCount = 1;
  pinfo.pWaitSemaphores = &rendered_[index];
  pinfo.swapchainCount = 1;
  pinfo.pSwapchains = &swapchain_;
  pinfo.pImageIndices = &index;
  r = vkQueuePresentKHR(ctx_->queue(), &pinfo);
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) return false;
  if (r != VK_SUCCESS) return vk::vk_error(r, "vkQueuePresentKHR");
  return true;
}

}  // namespace mds::viewer
