#include "vk/pipeline_cache.h"

#include <cstdlib>
#include <vector>

namespace mds::vk {
namespace {

template <class T>
void put(std::string& k, const T& v) {
  k.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

void put_string(std::string& k, const std::string& s) {
  put(k, uint64_t(s.size()));
  k += s;
}

void put_spec(std::string& k, const SpecConstants* spec) {
  put_string(k, spec ? spec->key() : std::string());
}

}  // namespace

PipelineCache::PipelineCache(VkDevice device) : device_(device) {
  const char* e = std::getenv("MDSTREAM_PIPELINE_REUSE");
  reuse_ = !(e && std::string(e) == "0");
}

PipelineCache::~PipelineCache() {
  pipelines_.clear();  // before the layouts they were made with
  layouts_.clear();
}

Result<VkPipelineLayout> PipelineCache::layout(std::span<const DescriptorSet* const> sets,
                                               uint32_t push_constant_bytes) {
  std::string key;
  put(key, push_constant_bytes);
  put(key, uint64_t(sets.size()));
  for (const DescriptorSet* s : sets) {
    put(key, uint64_t(s->bindings().size()));
    for (const VkDescriptorSetLayoutBinding& b : s->bindings()) {
      put(key, b.binding);
      put(key, b.descriptorType);
      put(key, b.descriptorCount);
      put(key, b.stageFlags);
      put(key, b.pImmutableSamplers);
    }
  }
  std::lock_guard lock(mutex_);
  if (!reuse_) put(key, made_++);
  if (auto it = layouts_.find(key); it != layouts_.end()) return it->second.layout.get();
  Layout l;
  std::vector<VkDescriptorSetLayout> handles;
  for (const DescriptorSet* s : sets) {
    VkDescriptorSetLayoutCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    info.bindingCount = uint32_t(s->bindings().size());
    info.pBindings = s->bindings().data();
    VkDescriptorSetLayout h = VK_NULL_HANDLE;
    MDS_VK_TRY(vkCreateDescriptorSetLayout(device_, &info, nullptr, &h));
    l.set_layouts.emplace_back(device_, h);
    handles.push_back(h);
  }
  VkPushConstantRange range{VK_SHADER_STAGE_ALL, 0, push_constant_bytes};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = uint32_t(handles.size());
  info.pSetLayouts = handles.data();
  info.pushConstantRangeCount = push_constant_bytes ? 1 : 0;
  info.pPushConstantRanges = &range;
  VkPipelineLayout h = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreatePipelineLayout(device_, &info, nullptr, &h));
  l.layout = UniquePipelineLayout(device_, h);
  layouts_.emplace(std::move(key), std::move(l));
  return h;
}

Result<VkPipeline> PipelineCache::compute(VkPipelineLayout layout, const std::string& shader, SpecConstants* spec) {
  std::string key = "compute";
  put(key, layout);
  put_string(key, shader);
  put_spec(key, spec);
  return find_or_make(std::move(key), [&] { return create_compute_pipeline(device_, layout, shader, spec); });
}

Result<VkPipeline> PipelineCache::graphics(VkPipelineLayout layout, const GraphicsPipelineDesc& desc) {
  std::string key = "graphics";
  put(key, layout);
  for (const std::string* s : {&desc.vertex_shader, &desc.fragment_shader, &desc.task_shader, &desc.mesh_shader})
    put_string(key, *s);
  put_spec(key, desc.vertex_spec);
  put_spec(key, desc.fragment_spec);
  put(key, uint64_t(desc.color_formats.size()));
  for (VkFormat f : desc.color_formats) put(key, f);
  put(key, desc.depth_format);
  put(key, uint8_t(desc.depth_test));
  put(key, uint8_t(desc.depth_write));
  put(key, desc.depth_compare);
  put(key, desc.topology);
  put(key, desc.cull);
  return find_or_make(std::move(key), [&] { return create_graphics_pipeline(device_, layout, desc); });
}

Result<VkPipeline> PipelineCache::find_or_make(std::string key, const std::function<Result<UniquePipeline>()>& make) {
  std::lock_guard lock(mutex_);
  if (!reuse_) put(key, made_++);
  if (auto it = pipelines_.find(key); it != pipelines_.end()) {
    ++reused_;
    return it->second.get();
  }
  MDS_ASSIGN_OR_RETURN(UniquePipeline p, make());
  const VkPipeline h = p.get();
  pipelines_.emplace(std::move(key), std::move(p));
  return h;
}

PipelineCache::Counts PipelineCache::counts() const {
  std::lock_guard lock(mutex_);
  return {layouts_.size(), pipelines_.size(), reused_};
}

}  // namespace mds::vk
