// Shader modules from embedded SPIR-V, descriptor sets, and compute/graphics pipeline helpers
// (dynamic rendering, specialization constants).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/check.h"

namespace mds::vk {

// Specialization constants: add(id, value) for 4-byte scalars (uint32, int32, float, VkBool32).
class SpecConstants {
 public:
  template <class T>
  SpecConstants& add(uint32_t id, T value) {
    static_assert(sizeof(T) == 4);
    VkSpecializationMapEntry e{id, uint32_t(data_.size()), sizeof(T)};
    entries_.push_back(e);
    data_.resize(data_.size() + sizeof(T));
    std::memcpy(data_.data() + e.offset, &value, sizeof(T));
    return *this;
  }
  // The constants as bytes (ids, offsets, sizes, values): equal bytes, equal specialization.
  std::string key() const {
    std::string k(reinterpret_cast<const char*>(entries_.data()), entries_.size() * sizeof(VkSpecializationMapEntry));
    k.append(reinterpret_cast<const char*>(data_.data()), data_.size());
    return k;
  }
  // Valid while this object lives and is not modified.
  const VkSpecializationInfo* info() {
    if (entries_.empty()) return nullptr;
    info_ = {uint32_t(entries_.size()), entries_.data(), data_.size(), data_.data()};
    return &info_;
  }

 private:
  std::vector<VkSpecializationMapEntry> entries_;
  std::vector<uint8_t> data_;
  VkSpecializationInfo info_{};
};

// A shader module created from shaders/<name> as embedded at build time.
Result<UniqueShaderModule> load_shader(VkDevice device, const std::string& name);

// One descriptor set layout + pool + set (the renderer binds a single set).
class DescriptorSet {
 public:
  static Result<DescriptorSet> create(VkDevice device, const std::vector<VkDescriptorSetLayoutBinding>& bindings);
  DescriptorSet() = default;
  DescriptorSet(DescriptorSet&&) = default;
  DescriptorSet& operator=(DescriptorSet&&) = default;

  void write_buffer(uint32_t binding, VkDescriptorType type, VkBuffer buffer, VkDeviceSize offset = 0,
                    VkDeviceSize range = VK_WHOLE_SIZE);
  void write_storage_image(uint32_t binding, VkImageView view, VkImageLayout layout = VK_IMAGE_LAYOUT_GENERAL);
  VkDescriptorSetLayout layout() const { return layout_.get(); }
  VkDescriptorSet set() const { return set_; }
  // The bindings it was created with (PipelineCache::layout keys on them).
  const std::vector<VkDescriptorSetLayoutBinding>& bindings() const { return bindings_; }

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  std::vector<VkDescriptorSetLayoutBinding> bindings_;
  UniqueDescriptorSetLayout layout_;
  UniqueDescriptorPool pool_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
};

Result<UniquePipelineLayout> create_pipeline_layout(VkDevice device, VkDescriptorSetLayout set_layout,
                                                    uint32_t push_constant_bytes = 0);

Result<UniquePipeline> create_compute_pipeline(VkDevice device, VkPipelineLayout layout, const std::string& shader,
                                               SpecConstants* spec = nullptr);

// A field added here joins PipelineCache::graphics's key (vk/pipeline_cache.cpp).
struct GraphicsPipelineDesc {
  std::string vertex_shader;  // empty when mesh_shader is set
  std::string fragment_shader;
  // Task/mesh pipeline (VK_EXT_mesh_shader must be enabled, Context::mesh_shaders()): the mesh
  // shader replaces the vertex stage; the task shader is optional. Vertex input and topology
  // are then unused.
  std::string task_shader;
  std::string mesh_shader;
  SpecConstants* vertex_spec = nullptr;
  SpecConstants* fragment_spec = nullptr;
  std::vector<VkFormat> color_formats;
  VkFormat depth_format = VK_FORMAT_UNDEFINED;
  bool depth_test = true;
  bool depth_write = true;
  VkCompareOp depth_compare = VK_COMPARE_OP_LESS;
  VkPrimitiveTopology topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkCullModeFlags cull = VK_CULL_MODE_NONE;
};

// Graphics pipeline for dynamic rendering; viewport and scissor are dynamic state.
Result<UniquePipeline> create_graphics_pipeline(VkDevice device, VkPipelineLayout layout,
                                                const GraphicsPipelineDesc& desc);

}  // namespace mds::vk
