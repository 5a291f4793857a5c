// The one exported symbol of libmdstream_vulkan.so (cli/vulkan_module.h): the Vulkan commands,
// registered in the module's own registry by cmd_render.cpp, cmd_stress.cpp and cmd_view.cpp.
// Everything else in the module is hidden (-fvisibility=hidden and --exclude-libs for the static
// libraries it contains).
#include "cli/vulkan_module.h"

extern "C" __attribute__((visibility("default"))) const void* mdstream_vulkan_module() {
  static const mds::cli::VulkanModuleApi api{mds::cli::kVulkanModuleAbi, &mds::cli::registry()};
  return &api;
}
