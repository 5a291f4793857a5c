// The task/mesh shader sprite path (issue 3: "a task/mesh shader path where VK_EXT_mesh_shader
// exists, selected at run time"). The default path -- and the only one on Debian 12's lavapipe
// (Mesa 22.3), which has no mesh shaders; Mesa 25's has them, tools/mesh_lavapipe.sh -- is
// compute + indirect draws: sphere_prepass.comp writes one glyph record
// per particle of the draw list, then points/quads are pulled by the vertex stage. On a device
// with task and mesh stages the same draw list instead feeds sphere.task (one invocation per
// listed meshlet: frustum test, then ceil(particles / 32) mesh workgroups) and sphere.mesh (the
// glyphs of include/sprite_make.h, four vertices and two triangles each, after the particle
// occlusion test where the frame runs it), with sphere.frag as the fragment stage: no
// per-particle records in memory and no pre-pass.
#pragma once

#include <string_view>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/check.h"

namespace mds::vk {
class Context;
}

namespace mds::render {

// --mesh-shaders: auto = compute + indirect draws, or the mesh path where the context enabled
// VK_EXT_mesh_shader (vk::Context::mesh_shaders()) and MDSTREAM_PREFER_MESH=1 is set
// (prefer_mesh_sprites(); tools/mesh_lavapipe.sh sets it so that the suites run the mesh path);
// on = the mesh path or an error; off = compute + indirect draws.
// Why auto is compute: on an NVIDIA H200 the compute path had the fastest frame on 23 of 28
// benchmark cases (1M particles, 640x360 and 1920x1080, culled and not; often 5-10x), the mesh
// path only on the porous close-up (docs/results/gpu-h200.md): compute rasterization of glyphs
// of a few pixels beats two triangles per glyph through the mesh stage.
enum class MeshShaderMode { automatic, off, on };
// MDSTREAM_PREFER_MESH is set to 1: `auto` takes the mesh path where the device has it.
bool prefer_mesh_sprites();
Result<MeshShaderMode> parse_mesh_shader_mode(std::string_view text);
const char* mesh_shader_mode_name(MeshShaderMode mode);
// Whether the renderer takes the mesh path on `ctx`; `on` without device support is an error
// that names the device.
Result<bool> use_mesh_sprites(const vk::Context& ctx, MeshShaderMode mode);

class MeshSprites {
 public:
  // Stages that read the draw list and the sprite draw header on this path (for the barriers
  // of the renderer before it rewrites them, and after).
  static constexpr VkPipelineStageFlags2 kReadStages =
      VK_PIPELINE_STAGE_2_TASK_SHADER_BIT_EXT | VK_PIPELINE_STAGE_2_MESH_SHADER_BIT_EXT;

  // Stages that write the visibility buffer on the visibility route (the mesh stage's small
  // glyphs, the fragments of the others).
  static constexpr VkPipelineStageFlags2 kVisibilityWriteStages =
      VK_PIPELINE_STAGE_2_MESH_SHADER_BIT_EXT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;

  // Precondition: ctx.mesh_shaders(). `layout` is the renderer's pipeline layout (set 0 of
  // include/bindings.h, all stages).
  // Attachment route (visibility false): the formats are those of the renderer's colour and
  // depth targets. Visibility route (precondition: the device has 64-bit buffer atomics): no
  // attachments, sphere_vis.mesh + sphere_vis.frag write the visibility buffer, and glyphs of at
  // most small_px pixels (<= 0 or NaN: none) are ray cast in the mesh stage.
  // particle_occlusion: also the pipeline with the particle occlusion test compiled in
  // (sphere.mesh specialization constant 0; RenderSettings::particle_occlusion).
  static Result<MeshSprites> create(const vk::Context& ctx, VkPipelineLayout layout, VkFormat color_format,
                                    VkFormat depth_format, bool visibility, float small_px,
                                    bool particle_occlusion);
  MeshSprites() = default;

  // Inside the rendering scope of the draw, with viewport and scissor set: one indirect mesh
  // task draw of `args` (VkDrawMeshTasksIndirectCommandEXT at `offset`: sprite_args.comp's
  // dispatch_x/y/z = ceil(draw list / kMeshTaskMeshlets), 1, 1). Precondition: the draw list
  // and `args` written by compute are visible to kReadStages and DRAW_INDIRECT, and the sprite
  // draw header's counters (zeroed by sprite_args.comp) to kReadStages' atomics.
  // particle_test: the frame runs the particle occlusion test (the frame uniforms carry the
  // pyramid levels); precondition: created with particle_occlusion.
  void record_draw(VkCommandBuffer cmd, VkDescriptorSet set, VkBuffer args, VkDeviceSize offset,
                   bool particle_test) const;

 private:
  VkPipeline pipe_ = VK_NULL_HANDLE;      // the context's (vk/pipeline_cache.h)
  VkPipeline occ_pipe_ = VK_NULL_HANDLE;  // with the particle occlusion test (when created with it)
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  PFN_vkCmdDrawMeshTasksIndirectEXT draw_indirect_ = nullptr;
};

}  // namespace mds::render
