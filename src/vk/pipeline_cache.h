// Pipelines kept for the life of the device (Context::pipelines()), so that renderers made one
// after another in a process compile each shader variant once: a series' frames
// (`render RUN.mds.series`, the viewer's Left/Right/Space), the viewer's slices, a test binary's
// cases. Not a VkPipelineCache (which keeps compiled code across processes where a driver
// supports it): this keeps the VkPipeline objects themselves, and with them what a driver builds
// on their first use. On lavapipe that was most of a renderer's creation (2M particles, 640x360):
// ~290 ms to create the culling loop's pipelines, and its warm-up dispatches took ~240 ms with
// new pipelines against ~130 ms with reused ones (llvmpipe's JIT variants, made on first use and
// kept with the pipeline); docs/rendering.md "Pipelines made once per process".
//
// Layouts are made by the cache too, one per definition (the descriptor set layouts' bindings
// and the push constant size), and live as long as the pipelines made with them. A caller
// allocates its descriptor sets from its own vk::DescriptorSet with the same bindings: Vulkan
// binds a set with any pipeline layout whose set layout is identically defined
// (VUID-vkCmdBindDescriptorSets-pDescriptorSets-00358).
//
// MDSTREAM_PIPELINE_REUSE=0 (A/B runs, tools/bench_series_render.py): every request makes a
// new pipeline (and layout), kept like the others until the Context goes.
//
// Thread-safe. The cache owns every handle it returns; they stay valid until the Context is
// destroyed (after vkDeviceWaitIdle).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <span>
#include <string>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/check.h"
#include "vk/pipeline.h"

namespace mds::vk {

class PipelineCache {
 public:
  explicit PipelineCache(VkDevice device);
  PipelineCache(const PipelineCache&) = delete;
  PipelineCache& operator=(const PipelineCache&) = delete;
  ~PipelineCache();  // precondition: no submitted work uses the cache's pipelines

  // The pipeline layout of these descriptor sets (set i = sets[i]'s bindings) and one push
  // constant range of `push_constant_bytes` (VK_SHADER_STAGE_ALL; 0: none).
  Result<VkPipelineLayout> layout(std::span<const DescriptorSet* const> sets, uint32_t push_constant_bytes = 0);
  // A compute / graphics pipeline; `layout` must come from layout() of this cache.
  Result<VkPipeline> compute(VkPipelineLayout layout, const std::string& shader, SpecConstants* spec = nullptr);
  Result<VkPipeline> graphics(VkPipelineLayout layout, const GraphicsPipelineDesc& desc);

  struct Counts {
    uint64_t layouts = 0;    // distinct layouts made
    uint64_t pipelines = 0;  // distinct pipelines made (compiled)
    uint64_t reused = 0;     // requests answered with a pipeline made before
  };
  Counts counts() const;

 private:
  // The pipeline of `key` (reuse_ off: a key made new), else the one `make` creates, kept.
  Result<VkPipeline> find_or_make(std::string key, const std::function<Result<UniquePipeline>()>& make);

  VkDevice device_;
  mutable std::mutex mutex_;
  // Keyed by the definitions' bytes (layouts) and by layout handle + shaders + specialization +
  // fixed state (pipelines).
  struct Layout {
    std::vector<UniqueDescriptorSetLayout> set_layouts;
    UniquePipelineLayout layout;
  };
  std::map<std::string, Layout> layouts_;
  std::map<std::string, UniquePipeline> pipelines_;
  uint64_t reused_ = 0;
  bool reuse_ = true;        // MDSTREAM_PIPELINE_REUSE != 0
  uint64_t made_ = 0;        // without reuse: a counter that makes each key new
};

}  // namespace mds::vk
