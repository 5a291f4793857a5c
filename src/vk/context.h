// Headless Vulkan context: instance (+ Khronos validation when requested and available),
// physical device selection, one logical device with a graphics+compute queue, the memory
// allocator and a one-shot submit helper. No window system, no surface.
//
// Device selection: `device_index >= 0` picks that physical device (as listed by enumerate());
// otherwise the first discrete GPU, then integrated, virtual, CPU (lavapipe) -- any device with
// Vulkan >= 1.3 and a queue family supporting graphics and compute.
//
// Window systems (the viewer): ContextOptions::instance_extensions/device_extensions are enabled
// in addition, and ContextOptions::make_surface, when set, creates a surface right after the
// instance; the context then owns it (surface()) and only accepts a queue family that supports
// graphics, compute and presenting to it. Without these options nothing changes (headless).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/memory.h"
#include "vk/pipeline_cache.h"

namespace mds::vk {

struct ContextOptions {
  int device_index = -1;   // -1: automatic
  bool validation = false; // enable VK_LAYER_KHRONOS_validation if present
  MemoryBudget budget;
  // Window system (optional; empty/null for headless use).
  std::vector<std::string> instance_extensions;  // e.g. from glfwGetRequiredInstanceExtensions
  std::vector<std::string> device_extensions;    // e.g. VK_KHR_swapchain
  std::function<Result<VkSurfaceKHR>(VkInstance)> make_surface;  // owned by the context afterwards
  // Reads MDSTREAM_VALIDATION=1 from the environment.
  static ContextOptions from_env();
};

struct DeviceInfo {
  uint32_t index = 0;
  std::string name;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  uint32_t api_version = 0;
  bool usable = false;       // Vulkan >= 1.3 with a graphics+compute queue
  bool mesh_shader = false;  // VK_EXT_mesh_shader present
};

const char* device_type_name(VkPhysicalDeviceType t);

class Context {
 public:
  static Result<std::unique_ptr<Context>> create(const ContextOptions& options);
  // Lists the physical devices (creates a temporary instance).
  static Result<std::vector<DeviceInfo>> enumerate();
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physical() const { return physical_; }
  VkDevice device() const { return device_; }
  VkQueue queue() const { return queue_; }
  // The surface made by ContextOptions::make_surface (VK_NULL_HANDLE when headless); queue()
  // can present to it.
  VkSurfaceKHR surface() const { return surface_; }
  uint32_t queue_family() const { return queue_family_; }
  const DeviceInfo& info() const { return info_; }
  const VkPhysicalDeviceProperties& properties() const { return props_; }
  // The device's limits, except maxStorageBufferRange: lowered to maxMemoryAllocationSize and
  // maxBufferSize where those are smaller, since every buffer the renderer binds whole is one
  // allocation (a GPU reporting a 4 GiB range may allocate less in one piece; lavapipe: 128 MiB,
  // unchanged). device_storage_range() is the device's own figure.
  const VkPhysicalDeviceLimits& limits() const { return props_.limits; }
  uint32_t device_storage_range() const { return device_storage_range_; }
  bool timestamps() const { return timestamp_valid_bits_ > 0; }
  double timestamp_period_ns() const { return props_.limits.timestampPeriod; }
  bool validation_enabled() const { return validation_; }
  // VK_EXT_mesh_shader enabled with its task and mesh stages (only where the device has them).
  bool mesh_shaders() const { return mesh_shaders_; }
  // shaderInt64 and shaderBufferInt64Atomics enabled (only where the device has both).
  bool int64_atomics() const { return int64_atomics_; }
  // Subgroup ballot operations in compute shaders (VkPhysicalDeviceSubgroupProperties).
  bool compute_ballot() const { return compute_ballot_; }
  // ... and shuffles (subgroupShuffle) too.
  bool compute_shuffle() const { return compute_shuffle_; }
  // ... and arithmetic reductions (subgroupAdd) too.
  bool compute_arithmetic() const { return compute_arithmetic_; }
  // Invocations per subgroup (VkPhysicalDeviceSubgroupProperties::subgroupSize; lavapipe 8).
  uint32_t subgroup_size() const { return subgroup_size_; }
  // Number of validation warnings/errors reported so far (0 without validation).
  uint64_t validation_messages() const;
  Allocator& allocator() { return *allocator_; }
  // Pipelines and their layouts, kept for the device's life (vk/pipeline_cache.h).
  PipelineCache& pipelines() const { return *pipelines_; }

  // Records `record` into a fresh primary command buffer, submits it and waits for completion.
  Status submit_and_wait(const std::function<void(VkCommandBuffer)>& record);
  // Submits an already recorded command buffer and waits.
  Status submit_and_wait(VkCommandBuffer cmd);

 private:
  Context() = default;
  struct Debug;

  VkInstance instance_ = VK_NULL_HANDLE;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  std::unique_ptr<Debug> debug_;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  uint32_t timestamp_valid_bits_ = 0;
  bool validation_ = false;
  bool mesh_shaders_ = false;
  bool int64_atomics_ = false;
  bool compute_ballot_ = false;
  bool compute_shuffle_ = false;
  bool compute_arithmetic_ = false;
  uint32_t subgroup_size_ = 0;
  DeviceInfo info_;
  VkPhysicalDeviceProperties props_{};
  uint32_t device_storage_range_ = 0;  // props_.limits.maxStorageBufferRange before the clamp above
  std::unique_ptr<Allocator> allocator_;
  std::unique_ptr<PipelineCache> pipelines_;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
};

}  // namespace mds::vk
