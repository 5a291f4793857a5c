#include "vk/embedded_shaders.h"

namespace mds::vk {

std::span<const uint32_t> find_shader(std::string_view name) {
  for (const auto& s : embedded_shaders())
    if (name == s.name) return s.spirv;
  return {};
}

}  // namespace mds::vk
