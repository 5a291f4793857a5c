// SPIR-V compiled from shaders/ at build time and embedded into the binary
// (generated source: <build>/generated/embedded_shaders.cpp, by src/vk/embed_spirv.cmake).
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace mds::vk {

struct EmbeddedShader {
  const char* name;  // source file name, e.g. "sphere.vert"
  std::span<const uint32_t> spirv;
};

std::span<const EmbeddedShader> embedded_shaders();
// The SPIR-V of shaders/<name>, or an empty span.
std::span<const uint32_t> find_shader(std::string_view name);

}  // namespace mds::vk
