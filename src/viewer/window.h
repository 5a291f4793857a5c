// The viewer's window: GLFW (X11 here, any platform GLFW supports) without a client API, a
// Vulkan surface made through vk::ContextOptions::make_surface, and a swapchain that shows a CPU
// image: the 8-bit frame is written into a host-visible staging buffer and copied into the
// acquired swapchain image (vkCmdCopyBufferToImage), then presented. One frame in flight.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/context.h"
#include "vk/memory.h"

struct GLFWwindow;

namespace mds::overlay {
class Canvas;
}

namespace mds::viewer {

using overlay::Canvas;

// GLFW library + one window. glfwInit/glfwTerminate are paired by this object.
class Window {
 public:
  static Result<std::unique_ptr<Window>> create(uint32_t width, uint32_t height, const std::string& title);
  ~Window();
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;

  GLFWwindow* handle() const { return window_; }
  bool should_close() const;
  // Framebuffer size in pixels (0 x 0 while minimised).
  void framebuffer_size(uint32_t& width, uint32_t& height) const;
  // Context options that add the window system's extensions and create this window's surface.
  void add_to_context_options(vk::ContextOptions& options) const;
  void set_title(const std::string& title);

 private:
  Window() = default;
  GLFWwindow* window_ = nullptr;
};

class Swapchain {
 public:
  static Result<std::unique_ptr<Swapchain>> create(vk::Context& ctx, uint32_t width, uint32_t height);
  ~Swapchain();
  Swapchain(const Swapchain&) = delete;
  Swapchain& operator=(const Swapchain&) = delete;

  // Recreates the swapchain for a new framebuffer size.
  Status resize(uint32_t width, uint32_t height);
  uint32_t width() const { return extent_.width; }
  uint32_t height() const { return extent_.height; }
  // Copies the canvas (top-left aligned; the rest of the window is cleared) and presents it.
  // Returns false when the swapchain is out of date (the caller resizes and presents again).
  Result<bool> present(const Canvas& canvas);
  VkFormat format() const { return format_; }

 private:
  Swapchain() = default;
  Status build(uint32_t width, uint32_t height);
  void destroy_swapchain();

  vk::Context* ctx_ = nullptr;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  bool bgra_ = true;
  VkExtent2D extent_{};
  std::vector<VkImage> images_;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkSemaphore acquired_ = VK_NULL_HANDLE;
  std::vector<VkSemaphore> rendered_;  // one per swapchain image
  vk::Buffer staging_;
};

}  // namespace mds::viewer
