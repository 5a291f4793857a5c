#include "vk/context.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace mds::vk {

struct Context::Debug {
  std::atomic<uint64_t> messages{0};
};

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                              VkDebugUtilsMessageTypeFlagsEXT,
                                              const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    static_cast<std::atomic<uint64_t>*>(user)->fetch_add(1);
    std::fprintf(stderr, "mdstream vulkan validation: %s\n", data->pMessage);
  }
  return VK_FALSE;
}

bool layer_available(const char* name) {
  uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  for (auto& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

bool instance_extension_available(const char* name) {
  uint32_t n = 0;
  vkEnumerateInstanceExtensionProperties(nullptr, &n, nullptr);
  std::vector<VkExtensionProperties> ext(n);
  vkEnumerateInstanceExtensionProperties(nullptr, &n, ext.data());
  for (auto& e : ext)
    if (std::strcmp(e.extensionName, name) == 0) return true;
  return false;
}

Result<VkInstance> create_instance(bool validation, const std::vector<std::string>& extra_extensions = {}) {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "mdstream";
  app.applicationVersion = VK_MAKE_VERSION(0, 1, 0);
  app.pEngineName = "mdstream";
  app.apiVersion = VK_API_VERSION_1_3;
  std::vector<const char*> layers, exts;
  if (validation) {
    layers.push_back(kValidationLayer);
    exts.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  for (const std::string& e : extra_extensions) {
    if (!instance_extension_available(e.c_str()))
      return make_error(Errc::unsupported, "Vulkan instance extension {} is not available", e);
    exts.push_back(e.c_str());
  }
  VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  info.pApplicationInfo = &app;
  info.enabledLayerCount = uint32_t(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = uint32_t(exts.size());
  info.ppEnabledExtensionNames = exts.data();
  VkInstance inst = VK_NULL_HANDLE;
  VkResult r = vkCreateInstance(&info, nullptr, &inst);
  if (r == VK_ERROR_INCOMPATIBLE_DRIVER || r == VK_ERROR_INITIALIZATION_FAILED)
    return make_error(Errc::unsupported, "no Vulkan 1.3 driver found (vkCreateInstance: {}); install mesa-vulkan-drivers",
                      vk_result_name(r));
  if (r != VK_SUCCESS) return vk_error(r, "vkCreateInstance");
  return inst;
}

// With a surface, the queue family must also support presenting to it.
DeviceInfo describe(VkPhysicalDevice pd, uint32_t index, uint32_t* family_out, VkSurfaceKHR surface = VK_NULL_HANDLE) {
  DeviceInfo d;
  d.index = index;
  VkPhysicalDeviceProperties p;
  vkGetPhysicalDeviceProperties(pd, &p);
  d.name = p.deviceName;
  d.type = p.deviceType;
  d.api_version = p.apiVersion;
  uint32_t nq = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, nullptr);
  std::vector<VkQueueFamilyProperties> q(nq);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, q.data());
  int family = -1;
  for (uint32_t i = 0; i < nq; ++i) {
    const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
    if ((q[i].queueFlags & need) == need) {
      if (surface != VK_NULL_HANDLE) {
        VkBool32 present = VK_FALSE;
        if (vkGetPhysicalDeviceSurfaceSupportKHR(pd, i, surface, &present) != VK_SUCCESS || !present) continue;
      }
      family = int(i);
      break;
    }
  }
  if (family_out && family >= 0) *family_out = uint32_t(family);
  d.usable = family >= 0 && p.apiVersion >= VK_API_VERSION_1_3;
  uint32_t ne = 0;
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &ne, nullptr);
  std::vector<VkExtensionProperties> ext(ne);
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &ne, ext.data());
  for (auto& e : ext)
    if (std::strcmp(e.extensionName, VK_EXT_MESH_SHADER_EXTENSION_NAME) == 0) d.mesh_shader = true;
  return d;
}

int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
    default: return 4;
  }
}

std::vector<VkPhysicalDevice> physical_devices(VkInstance inst) {
  uint32_t n = 0;
  vkEnumeratePhysicalDevices(inst, &n, nullptr);
  std::vector<VkPhysicalDevice> pds(n);
  vkEnumeratePhysicalDevices(inst, &n, pds.data());
  return pds;
}

}  // namespace

const char* device_type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

ContextOptions ContextOptions::from_env() {
  ContextOptions o;
  const char* v = std::getenv("MDSTREAM_VALIDATION");
  o.validation = v && std::strcmp(v, "0") != 0 && v[0] != '\0';
  return o;
}

Result<std::vector<DeviceInfo>> Context::enumerate() {
  MDS_ASSIGN_OR_RETURN(VkInstance inst, create_instance(false));
  std::vector<DeviceInfo> out;
  auto pds = physical_devices(inst);
  for (uint32_t i = 0; i < pds.size(); ++i) out.push_back(describe(pds[i], i, nullptr));
  vkDestroyInstance(inst, nullptr);
  return out;
}

Result<std::unique_ptr<Context>> Context::create(const ContextOptions& options) {
  std::unique_ptr<Context> c(new Context());
  c->validation_ = options.validation && layer_available(kValidationLayer) &&
                   instance_extension_available(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  MDS_ASSIGN_OR_RETURN(c->instance_, create_instance(c->validation_, options.instance_extensions));
  if (c->validation_) {
    c->debug_ = std::make_unique<Debug>();
    VkDebugUtilsMessengerCreateInfoEXT dinfo{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    dinfo.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    dinfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                        VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    dinfo.pfnUserCallback = debug_callback;
    dinfo.pUserData = &c->debug_->messages;
    auto fn = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(c->instance_, "vkCreateDebugUtilsMessengerEXT"));
    if (fn) fn(c->instance_, &dinfo, nullptr, &c->messenger_);
  }

  if (options.make_surface) {
    MDS_ASSIGN_OR_RETURN(c->surface_, options.make_surface(c->instance_));
  }
  const VkSurfaceKHR surface = c->surface_;

  auto pds = physical_devices(c->instance_);
  if (pds.empty()) return make_error(Errc::unsupported, "no Vulkan physical device found");
  int chosen = -1;
  if (options.device_index >= 0) {
    if (size_t(options.device_index) >= pds.size())
      return make_error(Errc::invalid_argument, "--device {}: only {} Vulkan device(s) present (0..{})",
                        options.device_index, pds.size(), pds.size() - 1);
    DeviceInfo d = describe(pds[options.device_index], options.device_index, &c->queue_family_, surface);
    if (!d.usable)
      return make_error(Errc::unsupported, "--device {} ({}): needs Vulkan 1.3 and a graphics+compute queue{}",
                        options.device_index, d.name, surface ? " that can present to the window" : "");
    chosen = options.device_index;
  } else {
    int best_rank = 1 << 30;
    for (uint32_t i = 0; i < pds.size(); ++i) {
      DeviceInfo d = describe(pds[i], i, nullptr, surface);
      if (d.usable && type_rank(d.type) < best_rank) {
        best_rank = type_rank(d.type);
        chosen = int(i);
      }
    }
    if (chosen < 0)
      return make_error(Errc::unsupported, "no Vulkan 1.3 device with a graphics+compute queue{}",
                        surface ? " that can present to the window" : "");
  }
  c->physical_ = pds[chosen];
  c->info_ = describe(c->physical_, uint32_t(chosen), &c->queue_family_, surface);
  vkGetPhysicalDeviceProperties(c->physical_, &c->props_);
  {  // subgroup ballots in compute (Vulkan 1.1 core properties): the renderer's pixel compaction
    VkPhysicalDeviceSubgroupProperties sg{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceMaintenance3Properties m3{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES};
    VkPhysicalDeviceMaintenance4Properties m4{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_4_PROPERTIES};
    VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    p2.pNext = &sg;
    sg.pNext = &m3;
    m3.pNext = &m4;  // Vulkan 1.3 core, which the device selection requires
    vkGetPhysicalDeviceProperties2(c->physical_, &p2);
    // A buffer bound whole is also allocated in one piece: the range the renderer sizes its
    // buffers by is the device's, lowered to the largest allocation and buffer (context.h).
    c->device_storage_range_ = c->props_.limits.maxStorageBufferRange;
    const uint64_t one_piece = std::min<uint64_t>(m3.maxMemoryAllocationSize, m4.maxBufferSize);
    if (one_piece > 0 && one_piece < c->props_.limits.maxStorageBufferRange)
      c->props_.limits.maxStorageBufferRange = uint32_t(one_piece);
    c->compute_ballot_ = (sg.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) != 0 &&
                         (sg.supportedOperations & VK_SUBGROUP_FEATURE_BALLOT_BIT) != 0;
    c->compute_shuffle_ = c->compute_ballot_ && (sg.supportedOperations & VK_SUBGROUP_FEATURE_SHUFFLE_BIT) != 0;
    c->compute_arithmetic_ = c->compute_shuffle_ && (sg.supportedOperations & VK_SUBGROUP_FEATURE_ARITHMETIC_BIT) != 0;
    c->subgroup_size_ = sg.subgroupSize;
  }
  {
    uint32_t nq = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(c->physical_, &nq, nullptr);
    std::vector<VkQueueFamilyProperties> q(nq);
    vkGetPhysicalDeviceQueueFamilyProperties(c->physical_, &nq, q.data());
    c->timestamp_valid_bits_ = q[c->queue_family_].timestampValidBits;
  }

  // Features: required 1.3 core (dynamic rendering, synchronization2); optional ones when present.
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  f12.pNext = &f13;
  VkPhysicalDeviceMeshShaderFeaturesEXT fmesh{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MESH_SHADER_FEATURES_EXT};
  if (c->info_.mesh_shader) f13.pNext = &fmesh;  // only chained when the extension exists
  VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  f2.pNext = &f12;
  vkGetPhysicalDeviceFeatures2(c->physical_, &f2);
  if (!f13.dynamicRendering || !f13.synchronization2)
    return make_error(Errc::unsupported, "device {} lacks dynamicRendering/synchronization2", c->info_.name);
  VkPhysicalDeviceVulkan13Features e13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  e13.dynamicRendering = VK_TRUE;
  e13.synchronization2 = VK_TRUE;
  e13.maintenance4 = f13.maintenance4;  // LocalSizeId (glslang emits it with specialization constants)
  VkPhysicalDeviceVulkan12Features e12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  e12.pNext = &e13;
  e12.drawIndirectCount = f12.drawIndirectCount;
  e12.hostQueryReset = f12.hostQueryReset;
  // 64-bit atomicMin on storage buffers: the renderer's compute rasterization of small sprites
  // (one atomic of depth bits and sprite index per pixel); enabled whenever supported.
  e12.shaderBufferInt64Atomics = f12.shaderBufferInt64Atomics && f2.features.shaderInt64;
  c->int64_atomics_ = e12.shaderBufferInt64Atomics == VK_TRUE;
  VkPhysicalDeviceFeatures2 e2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  e2.pNext = &e12;
  e2.features.multiDrawIndirect = f2.features.multiDrawIndirect;
  e2.features.drawIndirectFirstInstance = f2.features.drawIndirectFirstInstance;
  e2.features.fragmentStoresAndAtomics = f2.features.fragmentStoresAndAtomics;
  e2.features.vertexPipelineStoresAndAtomics = f2.features.vertexPipelineStoresAndAtomics;
  e2.features.shaderStorageImageWriteWithoutFormat = f2.features.shaderStorageImageWriteWithoutFormat;
  // Point sprites larger than one pixel (the renderer's point path); enabled whenever supported,
  // so "supported" (vkGetPhysicalDeviceFeatures) means "enabled" for this context.
  e2.features.largePoints = f2.features.largePoints;
  e2.features.shaderInt64 = e12.shaderBufferInt64Atomics;

  float priority = 1.0f;
  VkDeviceQueueCreateInfo qinfo{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qinfo.queueFamilyIndex = c->queue_family_;
  qinfo.queueCount = 1;
  qinfo.pQueuePriorities = &priority;
  std::vector<const char*> device_exts;
  for (const std::string& e : options.device_extensions) device_exts.push_back(e.c_str());
  // Task/mesh shaders (the renderer's mesh sprite path) whenever the device has both stages.
  VkPhysicalDeviceMeshShaderFeaturesEXT emesh{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MESH_SHADER_FEATURES_EXT};
  if (c->info_.mesh_shader && fmesh.taskShader && fmesh.meshShader) {
    emesh.taskShader = VK_TRUE;
    emesh.meshShader = VK_TRUE;
    e13.pNext = &emesh;
    device_exts.push_back(VK_EXT_MESH_SHADER_EXTENSION_NAME);
    c->mesh_shaders_ = true;
  }
  VkDeviceCreateInfo dinfo{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dinfo.pNext = &e2;
  dinfo.queueCreateInfoCount = 1;
  dinfo.pQueueCreateInfos = &qinfo;
  dinfo.enabledExtensionCount = uint32_t(device_exts.size());
  dinfo.ppEnabledExtensionNames = device_exts.data();
  MDS_VK_TRY(vkCreateDevice(c->physical_, &dinfo, nullptr, &c->device_));
  vkGetDeviceQueue(c->device_, c->queue_family_, 0, &c->queue_);
  c->allocator_ = std::make_unique<Allocator>(c->physical_, c->device_, options.budget);
  c->pipelines_ = std::make_unique<PipelineCache>(c->device_);

  VkCommandPoolCreateInfo pinfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pinfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT | VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pinfo.queueFamilyIndex = c->queue_family_;
  MDS_VK_TRY(vkCreateCommandPool(c->device_, &pinfo, nullptr, &c->pool_));
  VkFenceCreateInfo finfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  MDS_VK_TRY(vkCreateFence(c->device_, &finfo, nullptr, &c->fence_));
  return c;
}

Context::~Context() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    if (fence_) vkDestroyFence(device_, fence_, nullptr);
    if (pool_) vkDestroyCommandPool(device_, pool_, nullptr);
    pipelines_.reset();
    allocator_.reset();
    vkDestroyDevice(device_, nullptr);
  }
  if (messenger_) {
    auto fn = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    if (fn) fn(instance_, messenger_, nullptr);
  }
  if (surface_) vkDestroySurfaceKHR(instance_, surface_, nullptr);
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

uint64_t Context::validation_messages() const { return debug_ ? debug_->messages.load() : 0; }

Status Context::submit_and_wait(VkCommandBuffer cmd) {
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  MDS_VK_TRY(vkResetFences(device_, 1, &fence_));
  MDS_VK_TRY(vkQueueSubmit(queue_, 1, &submit, fence_));
  MDS_VK_TRY(vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX));
  return {};
}

Status Context::submit_and_wait(const std::function<void(VkCommandBuffer)>& record) {
  VkCommandBufferAllocateInfo ainfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ainfo.commandPool = pool_;
  ainfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ainfo.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  MDS_VK_TRY(vkAllocateCommandBuffers(device_, &ainfo, &cmd));
  struct Free {
    VkDevice d;
    VkCommandPool p;
    VkCommandBuffer c;
    ~Free() { vkFreeCommandBuffers(d, p, 1, &c); }
  } guard{device_, pool_, cmd};
  VkCommandBufferBeginInfo binfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  binfo.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  MDS_VK_TRY(vkBeginCommandBuffer(cmd, &binfo));
  record(cmd);
  MDS_VK_TRY(vkEndCommandBuffer(cmd));
  return submit_and_wait(cmd);
}

}  // namespace mds::vk
