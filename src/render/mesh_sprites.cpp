// The task/mesh shader sprite path; see mesh_sprites.h.
#include "render/mesh_sprites.h"

#include <algorithm>
#include <cstdlib>

#include "vk/context.h"
#include "vk/pipeline.h"

namespace mds::render {

Result<MeshShaderMode> parse_mesh_shader_mode(std::string_view text) {
  if (text == "auto") return MeshShaderMode::automatic;
  if (text == "off") return MeshShaderMode::off;
  if (text == "on") return MeshShaderMode::on;
  return make_error(Errc::invalid_argument, "--mesh-shaders '{}': expected auto, on or off", text);
}

const char* mesh_shader_mode_name(MeshShaderMode mode) {
  switch (mode) {
    case MeshShaderMode::automatic: return "auto";
    case MeshShaderMode::off: return "off";
    case MeshShaderMode::on: return "on";
  }
  return "?";
}

bool prefer_mesh_sprites() {
  const char* e = std::getenv("MDSTREAM_PREFER_MESH");
  return e && std::string_view(e) == "1";
}

Result<bool> use_mesh_sprites(const vk::Context& ctx, MeshShaderMode mode) {
  if (mode == MeshShaderMode::off) return false;
  if (mode == MeshShaderMode::automatic) return ctx.mesh_shaders() && prefer_mesh_sprites();
  if (mode == MeshShaderMode::on && !ctx.mesh_shaders())
    return make_error(Errc::unsupported,
                      "--mesh-shaders on: device '{}' has no VK_EXT_mesh_shader with task and mesh stages "
                      "(use --mesh-shaders auto or off: compute + indirect draws)",
                      ctx.info().name);
  return ctx.mesh_shaders();
}

Result<MeshSprites> MeshSprites::create(const vk::Context& ctx, VkPipelineLayout layout, VkFormat color_format,
                                        VkFormat depth_format, bool visibility, float small_px,
                                        bool particle_occlusion) {
  if (!ctx.mesh_shaders())
    return make_error(Errc::unsupported, "mesh sprite path: VK_EXT_mesh_shader is not enabled on '{}'",
                      ctx.info().name);
  MeshSprites m;
  m.layout_ = layout;
  m.draw_indirect_ = reinterpret_cast<PFN_vkCmdDrawMeshTasksIndirectEXT>(
      vkGetDeviceProcAddr(ctx.device(), "vkCmdDrawMeshTasksIndirectEXT"));
  if (!m.draw_indirect_)
    return make_error(Errc::unsupported, "mesh sprite path: '{}' exposes no vkCmdDrawMeshTasksIndirectEXT",
                      ctx.info().name);
  const bool vis = visibility;
  small_px = small_px > 0.0f ? small_px : 0.0f;  // NaN and negatives: none
  vk::GraphicsPipelineDesc g;
  g.task_shader = "sphere.task";
  if (vis) {  // no attachments: the mesh stage and the fragments write the visibility buffer
    g.mesh_shader = "sphere_vis.mesh";
    g.fragment_shader = "sphere_vis.frag";
    g.depth_test = false;
    g.depth_write = false;
  } else {
    g.mesh_shader = "sphere.mesh";
    g.fragment_shader = "sphere.frag";
    g.color_formats = {color_format};
    g.depth_format = depth_format;
  }
  // The mesh stage's specialization constants: 0 kParticleOcclusion, 1 kSmallPx.
  vk::SpecConstants spec;
  spec.add(0u, VkBool32(false)).add(1u, small_px);
  g.vertex_spec = &spec;
  MDS_ASSIGN_OR_RETURN(m.pipe_, ctx.pipelines().graphics(layout, g));
  if (particle_occlusion) {
    vk::SpecConstants occ;
    occ.add(0u, VkBool32(true)).add(1u, small_px);
    g.vertex_spec = &occ;
    MDS_ASSIGN_OR_RETURN(m.occ_pipe_, ctx.pipelines().graphics(layout, g));
  }
  return m;
}

void MeshSprites::record_draw(VkCommandBuffer cmd, VkDescriptorSet set, VkBuffer args, VkDeviceSize offset,
                              bool particle_test) const {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, particle_test && occ_pipe_ ? occ_pipe_ : pipe_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_, 0, 1, &set, 0, nullptr);
  draw_indirect_(cmd, args, offset, 1, sizeof(VkDrawMeshTasksIndirectCommandEXT));
}

}  // namespace mds::render
