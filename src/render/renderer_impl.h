// Private to the renderer's translation units (renderer.cpp: creation, render() and read-backs;
// renderer_record.cpp: the pass recording; renderer_progressive.cpp: set_view/step, streaming):
// the renderer's state.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "render/renderer.h"
#include "render/sample_pacer.h"
#include "render/streaming/stream_cache.h"
#include "vk/commands.h"
#include "vk/pipeline.h"
#include "vk/timestamps.h"

namespace mds::render {

inline constexpr uint32_t kTimingFrames = 4;  // draw-only frames after a convergence past spp
inline constexpr VkFormat kColorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
inline constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

struct Renderer::Impl {
  vk::Context* ctx = nullptr;
  RenderSettings settings;
  glm::dvec3 origin{0.0};
  Bounds bounds;
  Bounds clip_bounds;  // bounds with the cell drawn (cell_lines.h with_cell): the views' clip planes
  uint32_t meshlet_count = 0;
  uint64_t particle_count = 0;
  uint32_t max_meshlet = 0;
  uint32_t flags = 0;
  float radius_min = 0, radius_max = 0;
  bool has_property = false;                 // the store's per-particle property (--color-by property)
  float property_min = 0, property_max = 0;  // its range (property_q 0 and 65535)
  bool has_color = false;                    // the store's per-particle colours (--color-by color)
  uint64_t upload_bytes = 0;
  uint64_t scratch_bytes = 0;  // draw list + sprite buffers (sized by the slots)

  vk::Buffer nodes, meshlets, particles, types, radii, property, particle_color, draw_list, frame_ubo;
  // The buffers the passes bind: the owned ones above in memory, the pool's when streaming.
  VkBuffer meshlets_h = VK_NULL_HANDLE, particles_h = VK_NULL_HANDLE, radii_h = VK_NULL_HANDLE;
  VkBuffer property_h = VK_NULL_HANDLE, color_h = VK_NULL_HANDLE;
  VkBuffer meshlet_class_h = VK_NULL_HANDLE;  // streaming: the pool's class buffer for the cull loop
  vk::Buffer sprites, sprite_draw;  // pre-pass output: GpuSprite per listed particle, draw commands
  // The draw list is made into sprites and drawn sprite_chunks times per frame, chunk_meshlets
  // entries each (RenderSettings::sprite_capacity; gpu_types.h SpriteDrawHeader, "Chunks").
  uint32_t sprite_chunks = 1;
  // Visibility ids name particles (draw-list entry x max meshlet particles + local), not sprite
  // records: records reused chunk by chunk, or none (the task/mesh path).
  bool chunked_ids() const { return sprite_chunks > 1 || mesh_path; }
  uint32_t chunk_meshlets = 0;
  // The visibility route (RenderSettings::visibility_route, where the device has 64-bit buffer
  // atomics and the buffer fits maxStorageBufferRange; either sprite path): every sprite --
  // small ones rasterized in compute or in the mesh stage, the others by points/quads/mesh
  // triangles -- writes depth bits and
  // its index into one uint64 per pixel, and visibility_resolve.comp shades each pixel once and
  // accumulates. Otherwise the attachment route: colour + depth attachments, accumulate.comp.
  vk::Buffer visibility;
  bool vis_route = false;
  // Ambient occlusion is applied (RenderSettings::ao_*): the visibility resolve shades with it.
  bool ao_active() const { return vis_route && settings.ao_strength > 0.0 && settings.ao_radius > 0.0; }
  // Visibility route where the device has subgroup ballots in compute: the covered pixels of each
  // frame (gpu_types.h CoveredPixelsHeader, 4 B/pixel + 16; 1920x1080: 8.3 MB), listed by
  // visibility_compact.comp so that the resolve shades only those (otherwise a 16-byte buffer
  // that only keeps the binding valid, and a full-screen resolve).
  vk::Buffer covered;
  bool covered_list = false;
  // Which resolve a frame uses: the list pays a compaction pass (~10 ms at 1920x1080 on
  // lavapipe) and scattered per-pixel access, so where most pixels are covered the full-screen
  // resolve is cheaper. The first frame of a view uses the list and copies its count into
  // coverage_rb (host-visible); the following frames of the view use the list only while that
  // coverage is below RenderSettings::covered_list_max_coverage.
  vk::Buffer coverage_rb;
  bool coverage_probe_pending = false;  // the last list frame copied its count
  int64_t view_coverage = -1;           // covered pixels of this view's probe (-1: not known)
  bool last_resolve_listed = false;     // the last resolved frame used the list (stats)
  // RenderStats::covered_fraction of a w x h image: the probe's share of the pixels, -1 unknown.
  double covered_fraction(uint32_t w, uint32_t h) const {
    return view_coverage >= 0 ? double(view_coverage) / (double(w) * h) : -1.0;
  }
  bool targets_created = false;     // the route is decided by the first create_targets()
  bool point_sprites = false;       // small on-screen sprites drawn as points (see create_pipelines)
  float small_px = 0.0f;            // sprites up to this size rasterized in compute (0: none)
  bool mesh_path = false;           // task/mesh sprites instead of the pre-pass (render/mesh_sprites.h)
  MeshSprites mesh;                 // its pipeline (mesh_path only)
  // Stages that read the draw list and the sprite commands: the barriers before they are
  // rewritten and after they are written name these.
  VkPipelineStageFlags2 sprite_read_stages = VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT;
  vk::Image color, depth;  // the attachment route only
  // The accumulation (shaders/include/accumulation.h): a vec4 buffer where 16 B/pixel fits
  // maxStorageBufferRange (and RenderSettings::accumulation_buffer), else an rgba32f image; the
  // unused one is a 16-byte buffer or a 1x1 image, so both bindings stay valid.
  vk::Buffer accum_buf;
  vk::Image accum;
  bool accum_in_buffer = false;
  bool accum_pipe_in_buffer = false;  // the accumulation the resolve/accumulate pipeline was built for
  vk::DescriptorSet set;
  // Layout and pipelines: the context's (vk/pipeline_cache.h), kept for the next renderer.
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline draw_list_pipe = VK_NULL_HANDLE, sprite_args_pipe = VK_NULL_HANDLE, prepass_pipe = VK_NULL_HANDLE,
             raster_pipe = VK_NULL_HANDLE, sphere_pipe = VK_NULL_HANDLE, point_pipe = VK_NULL_HANDLE,
             cell_pipe = VK_NULL_HANDLE,  // the simulation cell's edges (cell_lines.vert), with settings.cell
             resolve_pipe = VK_NULL_HANDLE, full_resolve_pipe = VK_NULL_HANDLE, accum_pipe = VK_NULL_HANDLE,
             compact_pipe = VK_NULL_HANDLE;  // resolve_pipe: over the covered list
  // The pre-pass with the particle occlusion test compiled in (specialization constant 3), bound
  // in the frames whose uniforms switch the test on (particle_test, write_frame_uniforms); null
  // without culling or with RenderSettings::particle_occlusion off.
  VkPipeline prepass_occ_pipe = VK_NULL_HANDLE;
  bool particle_test = false;
  vk::FrameSlot slot;
  vk::TimestampPool timestamps;
  vk::DeferredDestroyer destroyer;
  uint64_t frame_index = 0;
  bool rendered = false;
  std::unique_ptr<culling::CullLoop> cull;  // occlusion culling (RenderSettings::cull)
  bool cull_active = false;                 // record a culling iteration in this pass
  uint32_t cull_iteration = 0;
  // Streaming: an iteration of this view has sampled occluders (CullCounters::selected > 0).
  bool view_sampled = false;
  std::function<void(uint32_t)> iteration_hook;

  // Named passes per frame: 3 per occlusion sampling pass and 2 of a route probe (select, sample;
  // sample_route.h kSampleRouteProbeShare), view (CullLoop::prepare_view)/pyramid/classify/histogram,
  // 4 drawing.
  uint32_t timestamp_capacity() const {
    return 25 + 3 * std::max(1u, settings.cull_settings.samples_per_iteration);
  }

  // Out-of-core (create_streaming): the cache; null in memory.
  const store::StoreReader* reader = nullptr;
  std::unique_ptr<streaming_gpu::StreamCache> cache;

  // Progressive state (set_view / step).
  Camera view_camera;
  std::vector<Camera> path_next;  // set_path_next(): the camera's next views, near/far fitted
  bool has_view = false;
  // A resize failed part way (a target of the new size could not be allocated: some of the old
  // ones are released already); step() and read_image() refuse until a resize succeeds.
  bool targets_lost = false;
  bool view_stale = false;     // resize(), set_c_occ(): the view restarts at the next set_view()/step()
  uint32_t samples = 0;        // accumulated in the current image
  uint32_t quiet = 0;          // sampling passes of the iterations since the last class change
  // Paced sampling at rest (RenderSettings::pace_sampling, render/sample_pacer.h).
  SamplePacer sample_pacer;
  bool moving = false;            // set_motion()
  double view_pass_ms = -1.0;     // per-pass sampling GPU ms of this view's last measured iteration
  uint32_t view_passes = 0;       // sampling passes of this view's completed iterations
  uint32_t iteration_passes = 0;  // passes of the iteration in flight ...
  uint32_t iteration_full = 0;    // ... and of an unpaced one (1 moving, else samples_per_iteration)
  uint32_t iteration_budget = 0;  // ... and its passes' occluder budget (CullLoop::pass_budget)
  bool iteration_moving = false;  // ... recorded while moving
  bool culling_converged = false;
  bool complete = true;        // streaming: the cache holds every wanted node
  bool pending_iteration = false;
  bool timestamps_reset = false;  // step() reset the timestamp pool this frame (pass "upload")
  uint64_t view_first_frame = 0;
  uint32_t view_complete_frames = 0;  // streaming: frames of this view until its first complete one (0: none yet)
  double view_complete_ms = -1.0;     //   ... and the wall time from set_view to its end
  std::vector<double> frame_gpu_ms, frame_wall_ms;  // per step() since set_view
  // The passes of the frame whose timestamps were collected last (Renderer::last_frame_gpu), and
  // the GPU ms collected outside step() (set_view, finish) that the next FrameReport reports.
  FrameGpu last_gpu;
  double unreported_gpu_ms = 0.0;
  CullStats view_cull;         // culling statistics of the current view
  std::chrono::steady_clock::time_point view_t0;

  Status upload(const SceneData& scene);
  // meshlet_slots: the draw list's capacity (the scene's meshlets, or the pool's meshlet slots).
  Status create_draw_buffers(uint64_t meshlet_slots);
  Status upload_streaming(const SceneData& directory);
  Status create_cull(const culling::CullScene& cs, const culling::DensityVolume& vol);
  Status change_culling(const std::function<void(culling::CullLoop&)>& apply);  // set_c_occ, set_coverage
  // The frame uniforms of one jittered sample of `camera` (render() and the progressive step()).
  // all_meshlets: a frame of every meshlet (no particle occlusion test).
  glm::dvec2 color_range() const;  // Renderer::color_range
  void write_frame_uniforms(const Camera& camera, uint32_t sample, uint32_t extra_flags = 0,
                            bool all_meshlets = false);
  // Collects the timestamps of the frame that completed last (0 when none was timed); sets
  // last_gpu when there were some.
  Result<double> collect_frame_ms();
  // RenderStats::sprites_* from the sprite pre-pass of the last drawn frame (waits for nothing:
  // the caller waited for the frame).
  Status read_sprite_counts(RenderStats& s);
  void after_iteration();
  Status create_targets();
  glm::vec3 background_linear() const {
    return {srgb_to_linear(settings.background_srgb.r), srgb_to_linear(settings.background_srgb.g),
            srgb_to_linear(settings.background_srgb.b)};
  }
  Status resize(uint32_t w, uint32_t h);
  Status create_pipelines();
  // The resolve or accumulate pipeline for the current accumulation (accum_in_buffer).
  Status create_accumulate_pipeline();
  // Writes the accumulation bindings (after create_targets).
  void write_accumulation_descriptors();
  // Binds the culling loop's confidence pyramid for the particle occlusion test (without culling
  // the test is off and the node buffer fills the binding); after create_cull() and every resize.
  void write_occlusion_descriptor();
  // The image of `sample_count` accumulated samples (>= 1; after the frame slot is idle), rgba
  // float per pixel, row-major: (sum of the covered samples' colours + background *
  // (sample_count - covered samples)) / sample_count, alpha = covered samples / sample_count.
  Result<std::vector<float>> read_average(uint32_t sample_count);
  // After the scene or the pool is on the device: targets, pipelines, frame slot, timestamps.
  Status create_frame_resources();
  // all_meshlets: draw every meshlet even when culling (the paired no-cull frames of render()).
  void record_pass(VkCommandBuffer cmd, bool first, bool accumulate = true, bool all_meshlets = false);
  void record_cull_only(VkCommandBuffer cmd);
  // `chunk`: which of the sprite_chunks (chunk 0 also clears the visibility buffer and zeroes the
  // chunk counter).
  void record_sprite_prepass(VkCommandBuffer cmd, uint32_t chunk);
  void record_small_raster(VkCommandBuffer cmd);
  void record_sprite_draws(VkCommandBuffer cmd);
  void record_draw_scope(VkCommandBuffer cmd, bool clear, bool last);
  Status create_cell_pipeline();  // cell_pipe for the current route
  void set_pixel_targets(vk::GraphicsPipelineDesc& g, const std::string& name) const;
};

// Errc::invalid_argument for --color-by property on a store without a property, or --color-by
// color on one without colours.
Status check_color_by(const ColorBy& c, bool has_property, bool has_color);


}  // namespace mds::render
