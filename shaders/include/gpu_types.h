// Structs shared between C++ and GLSL: the single definition of every GPU buffer record.
// C++ includes this header (types in namespace mds::gpu, glm types for vectors) and checks
// sizes/offsets with static_assert; GLSL includes it via GL_GOOGLE_include_directive.
// Layout rules used here (std430 for storage buffers, std140 for the uniform block): only
// vec4/uvec4/mat4 and `vec3 followed by one 4-byte scalar`, explicit padding to 16 bytes,
// so the C++ (alignas(16)) and GLSL layouts coincide.
#ifndef MDS_GPU_TYPES_H
#define MDS_GPU_TYPES_H

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
#define MDS_STRUCT(name) struct alignas(16) name
#define MDS_CONST(type, name, value) inline constexpr type name = value
#else
#define MDS_STRUCT(name) struct name
#define MDS_CONST(type, name, value) const type name = value
#endif

// Descriptor bindings of the renderer's single descriptor set (set 0).
MDS_CONST(uint, kBindFrame, 0);       // uniform FrameUniforms
MDS_CONST(uint, kBindNodes, 1);       // GpuNode[]
MDS_CONST(uint, kBindMeshlets, 2);    // GpuMeshlet[]
MDS_CONST(uint, kBindParticles, 3);   // uvec2[] = uint16 x, y, z, type per particle
MDS_CONST(uint, kBindTypes, 4);       // GpuType[]
MDS_CONST(uint, kBindDrawList, 5);    // DrawListHeader + uint meshlet_ids[]
MDS_CONST(uint, kBindRadii, 6);       // uint[] = two uint16 radius_q per uint (optional)
MDS_CONST(uint, kBindColorImage, 7);  // rgba32f storage image: the pass's colour target
MDS_CONST(uint, kBindAccumImage, 8);  // rgba32f storage image: the accumulation image

// FrameUniforms.flags
MDS_CONST(uint, kFrameOrtho, 1u);
MDS_CONST(uint, kFramePerParticleRadius, 2u);

// Per-frame constants (std140 uniform block).
MDS_STRUCT(FrameUniforms) {
  mat4 view;          // world (relative to the scene origin) -> view space, camera looks along -z
  mat4 proj;          // view -> clip (Vulkan: y down, depth 0..1), including the sub-pixel jitter
  mat4 inv_proj;      // clip -> view
  vec4 viewport;      // width, height, 1/width, 1/height
  vec4 radius_range;  // radius_min, radius_max - radius_min (per-particle radii), near, far
  uvec4 counts;       // meshlet_count, max_meshlet_particles, flags, sample index
};

// One store node: quantization frame relative to the scene origin (float is enough there).
MDS_STRUCT(GpuNode) {
  vec3 origin;          // center_min - scene origin
  uint first_particle;  // index of the node's first particle in the particle buffer
  vec3 step;            // (center_max - center_min) / 65535
  uint particle_count;
  vec3 aabb_min;        // centre bounds -/+ max_radius, relative to the scene origin
  float max_radius;
  vec3 aabb_max;
  uint first_meshlet;
};

// One meshlet: a run of particles of one node, with bounds computed at load from decoded positions.
MDS_STRUCT(GpuMeshlet) {
  vec3 aabb_min;        // sphere bounds (centres -/+ radius), relative to the scene origin
  uint node;
  vec3 aabb_max;
  uint first_particle;  // global index in the particle buffer
  uint particle_count;  // 1..255
  uint pad0;
  uint pad1;
  uint pad2;
};

// Per-type appearance.
MDS_STRUCT(GpuType) {
  vec4 color;           // linear RGB, a = 1
  float radius;
  uint pad0;
  uint pad1;
  uint pad2;
};

// Head of a draw list buffer: one VkDrawIndexedIndirectCommand, then meshlet ids, one per
// instance. The compute pass fills it; the draw reads it with vkCmdDrawIndexedIndirect.
MDS_STRUCT(DrawListHeader) {
  uint index_count;     // 6 * max_meshlet_particles (two triangles per particle)
  uint instance_count;  // number of meshlets in the list (atomic counter)
  uint first_index;
  int vertex_offset;
  uint first_instance;
  uint pad0;
  uint pad1;
  uint pad2;
};

#ifdef __cplusplus
static_assert(sizeof(FrameUniforms) == 240);
static_assert(offsetof(FrameUniforms, viewport) == 192);
static_assert(offsetof(FrameUniforms, counts) == 224);
static_assert(sizeof(GpuNode) == 64);
static_assert(offsetof(GpuNode, first_particle) == 12);
static_assert(offsetof(GpuNode, step) == 16);
static_assert(offsetof(GpuNode, max_radius) == 44);
static_assert(offsetof(GpuNode, first_meshlet) == 60);
static_assert(sizeof(GpuMeshlet) == 48);
static_assert(offsetof(GpuMeshlet, node) == 12);
static_assert(offsetof(GpuMeshlet, first_particle) == 28);
static_assert(offsetof(GpuMeshlet, particle_count) == 32);
static_assert(sizeof(GpuType) == 32);
static_assert(sizeof(DrawListHeader) == 32);
}  // namespace mds::gpu
#undef MDS_STRUCT
#undef MDS_CONST
#endif

#endif  // MDS_GPU_TYPES_H
