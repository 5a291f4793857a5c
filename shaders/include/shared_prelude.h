// The C++/GLSL shim of the headers shared between C++ and the shaders (gpu_types.h,
// cull_shared.h): in C++ the GLSL scalar/vector names as aliases in namespace mds::gpu
// (glm types), and the two macros that declare records and constants in both languages:
//   MDS_STRUCT(name)              C++: struct alignas(16) name   GLSL: struct name
//   MDS_CONST(type, name, value)  C++: inline constexpr          GLSL: const
// Deliberately without an include guard: each shared header includes it at its top and, in
// C++, #undefs the two macros at its end so that they do not leak into C++ code.
#ifdef __cplusplus
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
namespace mds::gpu {
using uint = uint32_t;
using vec3 = glm::vec3;
using vec4 = glm::vec4;
using uvec2 = glm::uvec2;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
}  // namespace mds::gpu
#endif

#ifndef MDS_STRUCT
#ifdef __cplusplus
#define MDS_STRUCT(name) struct alignas(16) name
#define MDS_CONST(type, name, value) inline constexpr type name = value
#else
#define MDS_STRUCT(name) struct name
#define MDS_CONST(type, name, value) const type name = value
#endif
#endif
