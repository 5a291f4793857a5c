// The Vulkan commands through a loadable module (core/module_loader.h). `bench`, `render`,
// `stress` and `view` need the Vulkan loader, libpng, tinyexr and GLFW with its X11 libraries;
// linked into the executable they cost every process start on the 2-core VM, also `convert`, `info`, `export`
// and `synth`, which never touch a GPU (an empty program: 2.9 ms; linked with -lvulkan: 4.9 ms,
// with -lglfw: 5.9 ms, with -lpng16 -ltinyexr: 4.7 ms; medians of 40). So the Vulkan commands
// (src/cli/vulkan/) and the libraries under them are built into libmdstream_vulkan.so, which
// main() opens when the command line names one of them or asks for the full help.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>
#include <vector>

#include "cli/command.h"

namespace mds::cli {

// The module's entry points, returned (as const void*) by its one exported function
// (kVulkanModuleSymbol). Both sides are compiled from this header in one build; kVulkanModuleAbi
// changes with the table or with Command. The module's commands are exactly kVulkanCommands
// (checked when it is loaded), so that main() knows without loading it which command lines need it.
inline constexpr uint32_t kVulkanModuleAbi = 1;
inline constexpr const char* kVulkanModuleSymbol = "mdstream_vulkan_module";
inline constexpr const char* kVulkanModuleFile = "libmdstream_vulkan.so";
inline constexpr std::array<std::string_view, 4> kVulkanCommands = {"bench", "render", "stress", "view"};

struct VulkanModuleApi {
  uint32_t abi = 0;
  const std::vector<Command>* commands = nullptr;  // the module's registry, in registration order
};

}  // namespace mds::cli
