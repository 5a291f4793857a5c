// Internal to the culling loop (cull_loop*.cpp, cull_sampling.cpp): its GPU state, CullLoop::Impl.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "gpu_types.h"
#include "render/culling/cull_loop.h"
#include "vk/commands.h"
#include "vk/pipeline.h"
#include "vk/staging.h"
#include "vk/timestamps.h"

namespace mds::render::culling {

inline constexpr VkFormat kSampleFormat = VK_FORMAT_R32G32_SFLOAT;  // (view depth, alpha_s): 8 B/px
inline constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;      // 4 B/px
inline constexpr VkBufferUsageFlags kSsbo =
    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;

// Compute/transfer writes before compute/transfer reads and writes.
void compute_barrier(VkCommandBuffer cmd);

struct CullLoop::Impl {
  vk::Context* ctx = nullptr;
  CullSettings settings;
  uint32_t width = 0, height = 0, bins = 0, budget = 0, levels = 0, passes = 1;
  uint32_t rest_budget = 0;  // set_resident_meshlets: the budget at rest (0: budget)
  // Passes per iteration at most (the numbering stride of the sampling passes).
  uint32_t max_passes() const { return std::max(1u, settings.samples_per_iteration); }
  uint32_t meshlet_count = 0, node_count = 0, max_meshlet = 0, frame_flags = 0;
  float radius_min = 0, radius_max = 0;
  uint64_t pyramid_texels = 0;
  // Density histogram blocks (CullSettings::histogram_stride): s x s pixels share one histogram.
  // The configured stride sizes the buffers; a view begun while moving casts coarser blocks
  // (kMovingHistogramStride, fewer of them: they fit).
  uint32_t configured_stride() const { return std::max(1u, settings.histogram_stride); }
  uint32_t view_stride = 0;  // the current view's stride (0: configured)
  uint32_t hist_stride() const { return view_stride ? view_stride : configured_stride(); }
  uint32_t hist_blocks_x() const { return (width + hist_stride() - 1) / hist_stride(); }
  uint32_t hist_blocks_y() const { return (height + hist_stride() - 1) / hist_stride(); }
  uint64_t hist_blocks() const { return uint64_t(hist_blocks_x()) * hist_blocks_y(); }
  uint32_t scene_flags = 0;  // kCullNodeDensity (CullUniforms.params.w, with kCullOrtho and kCullExtendDepth per view)
  float footprint_radius = 0.0f;  // CullScene::footprint_radius (the histograms' R with exact coverage)
  SceneBuffers scene;
  Camera camera;
  glm::dvec3 origin{0.0};
  gpu::CullUniforms uniforms{};
  glm::dmat4 view{1.0}, proj{1.0};

  vk::Buffer cull_ubo, frame_ubo, histogram, hist_range, pixel_state, pyramid, volume, volume_init;
  vk::Buffer meshlet_voxel_first, voxel_refs, own_meshlet_class, node_class, counters, counters_host, node_class_host;
  VkBuffer meshlet_class = VK_NULL_HANDLE;  // own_meshlet_class or the streaming pool's
  bool node_density = false;
  uint32_t node_extent = kNodeExtentInMemory;
  vk::Buffer occluder_list, indices;
  vk::Buffer normal_cdf;  // supplement A's table for cull_update.comp (culling_math.glsl)
  // Occlusion samples: the rasterized route renders into sample_image (+ depth); the compute
  // route (cull_sample.comp) writes sample_buf, 8 B per pixel (16 B when unavailable).
  bool compute_available = false;  // 64-bit atomics, W*H*8 fits, not forced to raster
  bool sample_compute = false;     // the route of the sampling pass recorded last
  // Automatic route choice (sample_route.h; cull_sampling.cpp times the passes).
  SampleRouteChooser route;
  uint32_t probe_share_recorded = 1;  // the budget divisor of the probe recorded last (its time counts this many times)
  uint32_t route_passes[2] = {0, 0};
  CullLoop::SampleRoutes routes_since;  // take_sample_routes()
  vk::TimestampPool route_ts;       // around the timed sampling passes (collect_route_timings)
  vk::Image sample_image, depth;
  vk::Buffer sample_buf;
  // Compute route: the pixels with a sample of the pass (cull_sample_compact.comp), so that the
  // update runs over those only; CoveredPixelsHeader + 4 B per pixel (16 B when unused).
  bool sampled_list = false;
  vk::Buffer sampled_pixels;
  // Which update a pass uses: the list pays a compaction and scattered access, so where most
  // pixels receive a sample (close-ups) the full-screen update is cheaper. A probe pass (cull_loop.h
  // kSampledListProbeIterations) takes the list and counts its pixels (CullCounters::sampled);
  // counters() keeps that count's fraction, and the other passes use the list only below
  // kSampledListMaxFraction.
  mutable double sampled_fraction = -1.0;  // -1: not measured in this view
  vk::DescriptorSet set0_sample, set0_draw, set1;
  VkPipelineLayout layout = VK_NULL_HANDLE;  // and the pipelines: the context's (vk/pipeline_cache.h)
  bool shared_box_tests = false;  // classify_pipe is cull_classify_coop.comp
  bool shared_cells = false;      // its kSharedCells (a shared test's cells one at a time)
  // Nodes per 64-lane workgroup of the node classification with one subgroup per node
  // (cull_classify_coop.comp push.mode 2: 64 / subgroupSize); 0: one thread per node (mode 0).
  uint32_t nodes_per_group = 0;
  VkPipeline classify_coarse_pipe = VK_NULL_HANDLE;  // kNodeExtentInMemory, while moving (set_moving); null when node_extent is that
  bool moving = false;
  bool view_pending = false;  // prepare_view ran; record_view_start not yet recorded
  uint32_t view_live = 0;     // its initial |P| (live meshlets)
  double moving_share = 1.0;  // set_moving: share of the budget per sampling pass while moving
  bool histogram_pending = false;  // the last iteration's classification may have changed the volume
  bool histogram_recast = false;   // the view's stride changed (set_moving(false)): cast every block
  VkPipeline reset_pipe = VK_NULL_HANDLE, histogram_pipe = VK_NULL_HANDLE, select_pipe = VK_NULL_HANDLE,
             update_pipe = VK_NULL_HANDLE, pyramid_pipe = VK_NULL_HANDLE, classify_pipe = VK_NULL_HANDLE,
             draw_list_pipe = VK_NULL_HANDLE, sample_pipe = VK_NULL_HANDLE, sample_comp_pipe = VK_NULL_HANDLE,
             update_buffer_pipe = VK_NULL_HANDLE, sample_compact_pipe = VK_NULL_HANDLE,
             update_list_pipe = VK_NULL_HANDLE;

  Status create_buffers(const CullScene& scene_data, const DensityVolume& vol);
  // A device-local storage buffer of `bytes` (at least 16) into b; an error naming `what` when
  // it exceeds maxStorageBufferRange.
  // keep_capacity: b is kept when it holds `bytes` (vk::ensure_buffer; the per-pixel buffers).
  Status make_ssbo(vk::Buffer& b, uint64_t bytes, const char* what, VkBufferUsageFlags extra = 0,
                   bool keep_capacity = false);
  Status create_pixel_buffers();
  void set_pixel_uniforms();
  void write_pixel_descriptors();
  Status create_sets();
  Status create_pipelines();
  bool sampled_list_wanted() const;  // CullSettings::sampled_pixel_list unless MDSTREAM_CULL_UPDATE=full
  SampleRoute forced_route() const;
  // The route of sampling pass p (of pass_count) of the iteration being recorded.
  bool choose_compute_route(uint32_t p, uint32_t pass_count);
  // kSampleRouteProbeShare, or MDSTREAM_CULL_PROBE_SHARE=N (A/B runs; 1: a whole pass).
  uint32_t probe_share() const;
  void begin_route_choice(VkCommandBuffer cmd);
  void bind(VkCommandBuffer cmd, VkPipelineBindPoint bp, VkPipeline pipe, const vk::DescriptorSet& s0) const;
  void push(VkCommandBuffer cmd, uint32_t mode, uint32_t pass = 0, glm::vec2 jitter = glm::vec2(0.0f)) const;
  void write_uniforms(uint32_t iteration);
  uint32_t pass_budget() const;  // CullLoop::pass_budget
  // The GPU half of a view begun by prepare_view (classes to P, counters, the density volume,
  // the cull buffers, the histograms), once: into the next recorded iteration's command buffer
  // (timestamped "view"), or submitted at once by begin_view.
  void record_view_start(VkCommandBuffer cmd, vk::TimestampPool* ts);
  void write_frame_uniforms(uint32_t iteration);
  // probe_share > 0: a probe (sample_route.h kSampleRouteProbeShare) -- 1 / probe_share of the
  // occluder budget, sampled and not applied (no update).
  void record_sampling_pass(VkCommandBuffer cmd, vk::TimestampPool* ts, uint32_t pass, uint32_t probe_share = 0);
  void record_update(VkCommandBuffer cmd, uint32_t pass);
  void record_pyramid(VkCommandBuffer cmd);
  void record_histogram(VkCommandBuffer cmd, uint32_t mode);
  template <class T>
  Result<std::vector<T>> read(const vk::Buffer& b, size_t count) {
    MDS_ASSIGN_OR_RETURN(auto raw, vk::read_buffer(*ctx, b, 0, count * sizeof(T)));
    std::vector<T> v(count);
    std::memcpy(v.data(), raw.data(), count * sizeof(T));
    return v;
  }
};

}  // namespace mds::render::culling
