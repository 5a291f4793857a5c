#include "vk/pipeline.h"

#include <map>
#include <utility>

#include "vk/embedded_shaders.h"

namespace mds::vk {

Result<UniqueShaderModule> load_shader(VkDevice device, const std::string& name) {
  auto spirv = find_shader(name);
  if (spirv.empty()) return make_error(Errc::internal, "shader {} is not embedded in this build", name);
  VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = spirv.size_bytes();
  info.pCode = spirv.data();
  VkShaderModule m = VK_NULL_HANDLE;
  VkResult r = vkCreateShaderModule(device, &info, nullptr, &m);
  if (r != VK_SUCCESS) return make_error(Errc::internal, "vkCreateShaderModule {}: {}", name, vk_result_name(r));
  return UniqueShaderModule(device, m);
}

Result<DescriptorSet> DescriptorSet::create(VkDevice device, const std::vector<VkDescriptorSetLayoutBinding>& bindings) {
  DescriptorSet d;
  d.device_ = device;
  d.bindings_ = bindings;
  VkDescriptorSetLayoutCreateInfo linfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  linfo.bindingCount = uint32_t(bindings.size());
  linfo.pBindings = bindings.data();
  VkDescriptorSetLayout layout = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreateDescriptorSetLayout(device, &linfo, nullptr, &layout));
  d.layout_ = UniqueDescriptorSetLayout(device, layout);
  std::map<VkDescriptorType, uint32_t> counts;
  for (auto& b : bindings) counts[b.descriptorType] += b.descriptorCount;
  std::vector<VkDescriptorPoolSize> sizes;
  for (auto& [t, n] : counts) sizes.push_back({t, n});
  VkDescriptorPoolCreateInfo pinfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pinfo.maxSets = 1;
  pinfo.poolSizeCount = uint32_t(sizes.size());
  pinfo.pPoolSizes = sizes.data();
  VkDescriptorPool pool = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreateDescriptorPool(device, &pinfo, nullptr, &pool));
  d.pool_ = UniqueDescriptorPool(device, pool);
  VkDescriptorSetAllocateInfo ainfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ainfo.descriptorPool = pool;
  ainfo.descriptorSetCount = 1;
  ainfo.pSetLayouts = &layout;
  MDS_VK_TRY(vkAllocateDescriptorSets(device, &ainfo, &d.set_));
  return d;
}

void DescriptorSet::write_buffer(uint32_t binding, VkDescriptorType type, VkBuffer buffer, VkDeviceSize offset,
                                 VkDeviceSize range) {
  VkDescriptorBufferInfo bi{buffer, offset, range};
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = set_;
  w.dstBinding = binding;
  w.descriptorCount = 1;
  w.descriptorType = type;
  w.pBufferInfo = &bi;
  vkUpdateDescriptorSets(device_, 1, &w, 0, nullptr);
}

void DescriptorSet::write_storage_image(uint32_t binding, VkImageView view, VkImageLayout layout) {
  VkDescriptorImageInfo ii{VK_NULL_HANDLE, view, layout};
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = set_;
  w.dstBinding = binding;
  w.descriptorCount = 1;
  w.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  w.pImageInfo = &ii;
  vkUpdateDescriptorSets(device_, 1, &w, 0, nullptr);
}

Result<UniquePipelineLayout> create_pipeline_layout(VkDevice device, VkDescriptorSetLayout set_layout,
                                                    uint32_t push_constant_bytes) {
  VkPushConstantRange range{VK_SHADER_STAGE_ALL, 0, push_constant_bytes};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = 1;
  info.pSetLayouts = &set_layout;
  info.pushConstantRangeCount = push_constant_bytes ? 1 : 0;
  info.pPushConstantRanges = &range;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreatePipelineLayout(device, &info, nullptr, &layout));
  return UniquePipelineLayout(device, layout);
}

Result<UniquePipeline> create_compute_pipeline(VkDevice device, VkPipelineLayout layout, const std::string& shader,
                                               SpecConstants* spec) {
  MDS_ASSIGN_OR_RETURN(UniqueShaderModule module, load_shader(device, shader));
  VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = module;
  info.stage.pName = "main";
  info.stage.pSpecializationInfo = spec ? spec->info() : nullptr;
  info.layout = layout;
  VkPipeline p = VK_NULL_HANDLE;
  VkResult r = vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &p);
  if (r != VK_SUCCESS) return make_error(Errc::internal, "compute pipeline {}: {}", shader, vk_result_name(r));
  return UniquePipeline(device, p);
}

Result<UniquePipeline> create_graphics_pipeline(VkDevice device, VkPipelineLayout layout,
                                                const GraphicsPipelineDesc& desc) {
  const bool mesh = !desc.mesh_shader.empty();
  // Stages in pipeline order: vertex, or [task,] mesh; then fragment.
  std::vector<std::pair<VkShaderStageFlagBits, const std::string*>> names;
  if (mesh) {
    if (!desc.task_shader.empty()) names.push_back({VK_SHADER_STAGE_TASK_BIT_EXT, &desc.task_shader});
    names.push_back({VK_SHADER_STAGE_MESH_BIT_EXT, &desc.mesh_shader});
  } else {
    names.push_back({VK_SHADER_STAGE_VERTEX_BIT, &desc.vertex_shader});
  }
  names.push_back({VK_SHADER_STAGE_FRAGMENT_BIT, &desc.fragment_shader});
  std::vector<UniqueShaderModule> modules;
  std::vector<VkPipelineShaderStageCreateInfo> stages;
  for (auto& [stage, name] : names) {
    MDS_ASSIGN_OR_RETURN(UniqueShaderModule m, load_shader(device, *name));
    VkPipelineShaderStageCreateInfo si{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    si.stage = stage;
    si.module = m;
    si.pName = "main";
    if (stage == VK_SHADER_STAGE_VERTEX_BIT || stage == VK_SHADER_STAGE_MESH_BIT_EXT)
      si.pSpecializationInfo = desc.vertex_spec ? desc.vertex_spec->info() : nullptr;
    if (stage == VK_SHADER_STAGE_FRAGMENT_BIT)
      si.pSpecializationInfo = desc.fragment_spec ? desc.fragment_spec->info() : nullptr;
    stages.push_back(si);
    modules.push_back(std::move(m));
  }

  VkPipelineVertexInputStateCreateInfo vin{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = desc.topology;
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.cullMode = desc.cull;
  rs.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  rs.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  ds.depthTestEnable = desc.depth_test;
  ds.depthWriteEnable = desc.depth_write;
  ds.depthCompareOp = desc.depth_compare;
  std::vector<VkPipelineColorBlendAttachmentState> blends(desc.color_formats.size());
  for (auto& b : blends)
    b.colorWriteMask =
        VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = uint32_t(blends.size());
  cb.pAttachments = blends.data();
  VkDynamicState dyn_states[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dyn{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dyn.dynamicStateCount = 2;
  dyn.pDynamicStates = dyn_states;
  VkPipelineRenderingCreateInfo rinfo{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  rinfo.colorAttachmentCount = uint32_t(desc.color_formats.size());
  rinfo.pColorAttachmentFormats = desc.color_formats.data();
  rinfo.depthAttachmentFormat = desc.depth_format;

  VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  info.pNext = &rinfo;
  info.stageCount = uint32_t(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = mesh ? nullptr : &vin;
  info.pInputAssemblyState = mesh ? nullptr : &ia;
  info.pViewportState = &vp;
  info.pRasterizationState = &rs;
  info.pMultisampleState = &ms;
  info.pDepthStencilState = &ds;
  info.pColorBlendState = &cb;
  info.pDynamicState = &dyn;
  info.layout = layout;
  VkPipeline p = VK_NULL_HANDLE;
  VkResult r = vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &p);
  if (r != VK_SUCCESS)
    return make_error(Errc::internal, "graphics pipeline {}{}+{}: {}", mesh ? desc.task_shader + "+" : "",
                      mesh ? desc.mesh_shader : desc.vertex_shader, desc.fragment_shader, vk_result_name(r));
  return UniquePipeline(device, p);
}

}  // namespace mds::vk
