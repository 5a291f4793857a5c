// The probabilistic occlusion culling loop on the GPU (paper 000, Sect. 3-5, Algorithm 1).
// See cull_loop.h; shaders: shaders/cull_*.comp. This file records the loop's passes; the
// occlusion sampling pass and its two routes live in cull_sampling.cpp, the buffers, sets and
// pipelines in cull_loop_resources.cpp, state readback in cull_loop_readback.cpp, the loop's
// state in cull_loop_impl.h.
#include "render/culling/cull_loop.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "render/culling/cull_loop_impl.h"

namespace mds::render::culling {

void compute_barrier(VkCommandBuffer cmd) {
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                         VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
}

uint32_t default_budget(uint32_t nodes, uint32_t meshlets) {
  return std::max<uint32_t>({1u, 2 * nodes, meshlets / kDefaultBudgetDivisor});
}

uint32_t bins_for(uint32_t width, uint32_t height, uint64_t max_storage_range, uint32_t requested) {
  const uint64_t per_bin = uint64_t(width) * height * sizeof(float);
  uint64_t fit = per_bin > 0 ? max_storage_range / per_bin : 0;
  uint64_t bins = std::min<uint64_t>(fit, MDS_CULL_HISTOGRAM_BINS);
  if (requested > 0) bins = std::min<uint64_t>(bins, requested);
  return uint32_t(bins);
}


CullScene cull_scene(const SceneData& s, const DensityVolume& vol) {
  CullScene c;
  c.origin = s.origin;
  c.meshlet_slots = uint32_t(s.meshlets.size());
  c.node_count = uint32_t(s.nodes.size());
  c.max_meshlet_particles = s.max_meshlet_particles;
  c.per_particle_radius = s.per_particle_radius;
  c.radius_min = s.radius_min;
  c.radius_max = s.radius_max;
  c.footprint_radius = smallest_radius(s);
  MeshletVoxels mv = meshlet_voxels(s, vol);
  c.voxel_first = std::move(mv.first);
  c.voxel_refs = std::move(mv.refs);
  return c;
}


void CullLoop::Impl::bind(VkCommandBuffer cmd, VkPipelineBindPoint bp, VkPipeline pipe,
                          const vk::DescriptorSet& s0) const {
  VkDescriptorSet sets[2] = {s0.set(), set1.set()};
  vkCmdBindPipeline(cmd, bp, pipe);
  vkCmdBindDescriptorSets(cmd, bp, layout, 0, 2, sets, 0, nullptr);
}

void CullLoop::Impl::push(VkCommandBuffer cmd, uint32_t mode, uint32_t pass, glm::vec2 jitter) const {
  gpu::CullPush p{mode, pass, jitter.x, jitter.y};
  vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_ALL, 0, sizeof(p), &p);
}

uint32_t CullLoop::Impl::pass_budget() const {
  if (!moving) return rest_budget > 0 ? rest_budget : budget;
  if (moving_share >= 1.0) return budget;
  return std::max(1u, uint32_t(std::lround(double(budget) * moving_share)));
}

void CullLoop::Impl::write_uniforms(uint32_t iteration) {
  uniforms.counts.z = iteration;
  uniforms.params.z = pass_budget();  // cull_select.comp
  std::memcpy(cull_ubo.mapped(), &uniforms, sizeof(uniforms));
  cull_ubo.flush();
}

void CullLoop::Impl::write_frame_uniforms(uint32_t iteration) {
  // Unjittered: each sampling pass adds its own sub-pixel jitter (push constant).
  const double aspect = double(width) / double(height);
  const glm::dmat4 p = projection_matrix(camera, aspect);
  gpu::FrameUniforms fu{};
  fu.view = glm::mat4(view);
  fu.proj = glm::mat4(p);
  fu.inv_proj = glm::mat4(glm::inverse(p));
  fu.viewport = glm::vec4(float(width), float(height), 1.0f / float(width), 1.0f / float(height));
  fu.radius_range = glm::vec4(radius_min, radius_max - radius_min, float(camera.near), float(camera.far));
  fu.counts = glm::uvec4(meshlet_count, max_meshlet,
                         frame_flags | (camera.ortho ? gpu::kFrameOrtho : 0u) |
                             (settings.coverage != Coverage::expected ? gpu::kFrameExactCoverage : 0u) |
                             (settings.coverage == Coverage::automatic ? gpu::kFrameMixedCoverage : 0u),
                         iteration);
  std::memcpy(frame_ubo.mapped(), &fu, sizeof(fu));
  frame_ubo.flush();
}

void CullLoop::Impl::record_update(VkCommandBuffer cmd, uint32_t pass) {
  // The probe: the first pass of every kSampledListProbeIterations-th iteration, and every pass
  // until a count arrived (the fraction changes little within a view once its first occluders
  // are sampled).
  const bool probe = sampled_fraction < 0.0 || pass % (passes * kSampledListProbeIterations) == 0;
  if (sample_compute && sampled_list && update_list_pipe && (probe || sampled_fraction < kSampledListMaxFraction)) {
    // List the sampled pixels (cull_sample_compact.comp), then update those (one thread each).
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT,
                       VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    const gpu::CoveredPixelsHeader head{gpu::kCoveredGroupsX, 0u, 1u, 0u};
    vkCmdUpdateBuffer(cmd, sampled_pixels.get(), 0, sizeof(head), &head);
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sample_compact_pipe, set0_sample);
    push(cmd, 0, pass);
    vkCmdDispatch(cmd, (width + 15) / 16, (height + 15) / 16, 1);
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, update_list_pipe, set0_sample);
    push(cmd, 0, pass);
    vkCmdDispatchIndirect(cmd, sampled_pixels.get(), offsetof(gpu::CoveredPixelsHeader, dispatch_x));
    if (probe) {  // the count to CullCounters::sampled (read back with the counters)
      vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
      const VkBufferCopy region{offsetof(gpu::CoveredPixelsHeader, count), offsetof(gpu::CullCounters, sampled), 4};
      vkCmdCopyBuffer(cmd, sampled_pixels.get(), counters.get(), 1, &region);
      vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                         VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                             VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
    }
  } else {
    bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sample_compute ? update_buffer_pipe : update_pipe, set0_sample);
    push(cmd, 0, pass);
    vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1);
  }
  compute_barrier(cmd);
}

void CullLoop::Impl::record_pyramid(VkCommandBuffer cmd) {
  bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pyramid_pipe, set0_sample);
  uint32_t w = width, h = height;
  for (uint32_t l = 1; l < levels; ++l) {
    w = (w + 1) / 2;
    h = (h + 1) / 2;
    push(cmd, l);
    vkCmdDispatch(cmd, (w + 7) / 8, (h + 7) / 8, 1);
    compute_barrier(cmd);
  }
}

void CullLoop::Impl::record_histogram(VkCommandBuffer cmd, uint32_t mode) {
  bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, histogram_pipe, set0_sample);
  push(cmd, mode);
  vkCmdDispatch(cmd, (hist_blocks_x() + 7) / 8, (hist_blocks_y() + 7) / 8, 1);
  compute_barrier(cmd);
}

Result<std::unique_ptr<CullLoop>> CullLoop::create(vk::Context& ctx, const SceneData& scene,
                                                   const DensityVolume& volume, const SceneBuffers& buffers,
                                                   uint32_t width, uint32_t height, const CullSettings& settings) {
  if (scene.meshlets.empty()) return make_error(Errc::invalid_argument, "culling: the scene has no meshlets");
  return create(ctx, cull_scene(scene, volume), volume, buffers, width, height, settings);
}

Result<std::unique_ptr<CullLoop>> CullLoop::create(vk::Context& ctx, const CullScene& scene,
                                                   const DensityVolume& volume, const SceneBuffers& buffers,
                                                   uint32_t width, uint32_t height, const CullSettings& settings) {
  if (scene.meshlet_slots == 0) return make_error(Errc::invalid_argument, "culling: the scene has no meshlets");
  const size_t csr = size_t(scene.node_density ? scene.node_count : scene.meshlet_slots) + 1;
  if (scene.voxel_first.size() != csr || scene.voxel_first.back() != scene.voxel_refs.size())
    return make_error(Errc::invalid_argument, "culling: voxel lists: {} index entries for {} {} and {} refs",
                      scene.voxel_first.size(), csr - 1, scene.node_density ? "nodes" : "meshlets",
                      scene.voxel_refs.size());
  if (volume.counts.size() != size_t(volume.dims.x) * volume.dims.y * volume.dims.z || volume.counts.empty())
    return make_error(Errc::invalid_argument, "culling: density volume dims/counts mismatch");
  if (settings.acceptance != MDS_CULL_ACCEPT_NORMAL && settings.acceptance != MDS_CULL_ACCEPT_RANDOM)
    return make_error(Errc::invalid_argument, "culling: acceptance mode {} not available on the GPU",
                      settings.acceptance);
  std::unique_ptr<CullLoop> loop(new CullLoop());
  loop->impl_ = std::make_unique<Impl>();
  Impl& m = *loop->impl_;
  m.ctx = &ctx;
  m.settings = settings;
  m.width = width;
  m.height = height;
  m.scene = buffers;
  m.origin = scene.origin;
  m.meshlet_count = scene.meshlet_slots;
  m.node_count = scene.node_count;
  m.max_meshlet = scene.max_meshlet_particles;
  m.meshlet_class = buffers.meshlet_class;
  m.node_density = scene.node_density;
  m.node_extent = std::clamp<uint32_t>(scene.node_extent, 1, 1024);
  m.frame_flags = scene.per_particle_radius ? gpu::kFramePerParticleRadius : 0u;  // kFrameExactCoverage per view
  m.radius_min = scene.radius_min;
  m.radius_max = scene.radius_max;
  m.bins = bins_for(width, height, ctx.limits().maxStorageBufferRange, settings.bins);
  if (m.bins == 0)
    return make_error(Errc::budget, "culling: one histogram bin for {}x{} pixels exceeds maxStorageBufferRange ({})",
                      width, height, ctx.limits().maxStorageBufferRange);
  m.budget = settings.budget > 0 ? settings.budget : default_budget(m.node_count, m.meshlet_count);
  m.passes = std::max(1u, settings.samples_per_iteration);
  MDS_TRY(m.create_buffers(scene, volume));
  MDS_TRY(m.create_sets());
  MDS_TRY(m.create_pipelines());
  // Two timestamps per sampling pass of one iteration (the automatic route choice).
  // The sampling passes of one iteration and a probe (cull_sampling.cpp).
  MDS_ASSIGN_OR_RETURN(m.route_ts, vk::TimestampPool::create(ctx, std::max(1u, settings.samples_per_iteration) + 1));
  return loop;
}

CullLoop::~CullLoop() = default;

uint32_t CullLoop::bins() const { return impl_->bins; }
uint32_t CullLoop::budget() const { return impl_->rest_budget > 0 ? impl_->rest_budget : impl_->budget; }
void CullLoop::set_resident_meshlets(uint32_t live, bool filling) {
  Impl& m = *impl_;
  const double share = m.settings.max_resident_share;
  m.rest_budget = 0;
  if (m.settings.budget > 0 || !(share < 1.0) || !filling) return;
  const auto cap = uint32_t(std::clamp(std::floor(double(live) * share), 1.0, double(UINT32_MAX)));
  m.rest_budget = std::min(m.budget, cap);
}
uint32_t CullLoop::pass_budget() const { return impl_->pass_budget(); }
uint32_t CullLoop::samples_per_iteration() const { return impl_->passes; }
void CullLoop::set_samples_per_iteration(uint32_t passes) {
  impl_->passes = std::clamp(passes, 1u, std::max(1u, impl_->settings.samples_per_iteration));
}
void CullLoop::set_moving(bool moving, double budget_share) {
  Impl& m = *impl_;
  m.moving = moving;
  m.moving_share = budget_share > 0.0 && budget_share <= 1.0 ? budget_share : 1.0;
  // At rest, a view begun while moving goes on with the configured histogram blocks: cast again
  // (all of them) before its next sampling pass; its classes stay.
  if (!moving && m.hist_stride() != m.configured_stride()) {
    m.view_stride = m.configured_stride();
    m.set_pixel_uniforms();
    m.histogram_recast = true;
  }
}
uint32_t CullLoop::view_histogram_stride() const { return impl_->hist_stride(); }
uint32_t CullLoop::pyramid_levels() const { return impl_->levels; }
VkBuffer CullLoop::pyramid_buffer() const { return impl_->pyramid.get(); }
void CullLoop::set_c_occ(double c_occ) {
  impl_->settings.c_occ = c_occ;
  impl_->uniforms.thresholds.x = float(c_occ);
}
void CullLoop::set_coverage(Coverage coverage) { impl_->settings.coverage = coverage; }
const CullSettings& CullLoop::settings() const { return impl_->settings; }
uint32_t CullLoop::width() const { return impl_->width; }
uint32_t CullLoop::height() const { return impl_->height; }

Status CullLoop::resize(uint32_t width, uint32_t height) {
  Impl& m = *impl_;
  if (width == 0 || height == 0) return make_error(Errc::invalid_argument, "culling: resize to {}x{}", width, height);
  if (width == m.width && height == m.height) return {};
  m.sampled_fraction = -1.0;
  const uint32_t bins = bins_for(width, height, m.ctx->limits().maxStorageBufferRange, m.settings.bins);
  if (bins == 0)
    return make_error(Errc::budget, "culling: one histogram bin for {}x{} pixels exceeds maxStorageBufferRange ({})",
                      width, height, m.ctx->limits().maxStorageBufferRange);
  m.width = width;
  m.height = height;
  m.bins = bins;
  if (Status st = m.create_pixel_buffers(); !st.ok()) {  // the old ones are released (the caller waited for the GPU)
    m.width = m.height = 0;  // a retry at this size makes them again
    return st;
  }
  m.set_pixel_uniforms();
  m.write_pixel_descriptors();
  return {};
}


Status CullLoop::prepare_view(const Camera& camera, uint32_t live_meshlets) {
  impl_->sampled_fraction = -1.0;  // the new view probes its sampled fraction again
  Impl& m = *impl_;
  m.route.new_view();  // a new view may favour the other sampling route
  m.histogram_pending = false;  // cast below for the new view
  m.histogram_recast = false;
  m.view_stride = m.moving ? std::max(m.configured_stride(), kMovingHistogramStride) : m.configured_stride();
  m.set_pixel_uniforms();
  if (!(camera.near > 0.0 && camera.far > camera.near))
    return make_error(Errc::invalid_argument, "culling: begin_view needs fitted near/far planes");
  m.camera = camera;
  const double aspect = double(m.width) / double(m.height);
  m.view = view_matrix(camera, m.origin);
  m.proj = projection_matrix(camera, aspect);
  gpu::CullUniforms& u = m.uniforms;
  u.view = glm::mat4(m.view);
  u.inv_view = glm::mat4(glm::inverse(m.view));
  u.proj = glm::mat4(m.proj);
  const double focal_px = 0.5 * m.height * std::abs(m.proj[1][1]);
  const double pixel_w = 2.0 / (std::abs(m.proj[0][0]) * m.width), pixel_h = 2.0 / (std::abs(m.proj[1][1]) * m.height);
  u.camera = glm::vec4(float(focal_px), float(pixel_w * pixel_h), float(camera.near), float(camera.far));
  // Exact and automatic clip samples against their pixels (automatic: those of particles below
  // kMixedExactBelowPx): the histograms count every particle that can reach a pixel, and
  // Algorithm 1 may move the representative depth back.
  const bool clipped = m.settings.coverage != Coverage::expected;
  u.thresholds.z = clipped ? m.footprint_radius : 0.0f;
  u.params.w = (camera.ortho ? gpu::kCullOrtho : 0u) | m.scene_flags | (clipped ? gpu::kCullExtendDepth : 0u);
  m.write_uniforms(0);
  m.view_live = std::min(live_meshlets, m.meshlet_count);
  m.view_pending = true;
  return {};
}

void CullLoop::Impl::record_view_start(VkCommandBuffer cmd, vk::TimestampPool* ts) {
  if (!view_pending) return;
  view_pending = false;
  if (ts) ts->begin(cmd, "view");
  // After whatever the command buffer holds before it (the cache's uploads fill the classes of
  // new pool pages with P, which this fill repeats), before the iteration that reads it.
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  gpu::CullCounters c{};
  c.class_count[MDS_CULL_CLASS_P] = view_live;
  vkCmdFillBuffer(cmd, meshlet_class, 0, VK_WHOLE_SIZE, 0);
  vkCmdFillBuffer(cmd, node_class.get(), 0, VK_WHOLE_SIZE, 0);
  vkCmdUpdateBuffer(cmd, counters.get(), 0, sizeof(c), &c);
  VkBufferCopy bc{0, 0, volume.size()};
  vkCmdCopyBuffer(cmd, volume_init.get(), volume.get(), 1, &bc);
  compute_barrier(cmd);
  bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, reset_pipe, set0_sample);
  push(cmd, 0);
  vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1);
  compute_barrier(cmd);
  record_histogram(cmd, 1);
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  if (ts) ts->end(cmd);
}

Status CullLoop::begin_view(const Camera& camera, uint32_t live_meshlets) {
  MDS_TRY(prepare_view(camera, live_meshlets));
  return impl_->ctx->submit_and_wait([&](VkCommandBuffer cmd) { impl_->record_view_start(cmd, nullptr); });
}

Status CullLoop::warm_up(const Camera& camera) {
  Impl& m = *impl_;
  const SampleRouteChooser route = m.route;  // the warm-up's passes choose nothing
  const uint32_t route_passes[2] = {m.route_passes[0], m.route_passes[1]};
  const SampleRoutes routes_since = m.routes_since;
  const bool moving = m.moving;
  Status st;
  for (bool mv : {false, true}) {  // at rest and moving: their classify pipelines differ
    m.moving = mv;
    st = begin_view(camera, 0);
    if (st.ok()) st = m.ctx->submit_and_wait([&](VkCommandBuffer cmd) { record_iteration(cmd, nullptr, 0); });
    if (!st.ok()) break;
  }
  m.moving = moving;
  m.route = route;
  m.route_passes[0] = route_passes[0];
  m.route_passes[1] = route_passes[1];
  m.routes_since = routes_since;  // the warm-up's passes are no frame's
  m.histogram_pending = false;
  return st;
}

void CullLoop::record_iteration(VkCommandBuffer cmd, vk::TimestampPool* ts, uint32_t iteration) {
  Impl& m = *impl_;
  m.record_view_start(cmd, ts);  // a view begun by prepare_view: its reset comes first
  m.write_uniforms(iteration);
  m.write_frame_uniforms(iteration);
  auto begin = [&](const char* name) {
    if (ts) ts->begin(cmd, name);
  };
  auto end = [&]() {
    if (ts) ts->end(cmd);
  };
  // Sect. 3.2: several occlusion sampling passes per iteration, each with its own occluder subset.
  // Eq. 9-11 after the previous iteration's volume update (a no-op on the GPU when nothing reached
  // O). Cast here rather than at the end of that iteration: a view that ends (new camera,
  // begin_view casts for the new one; converged) never pays for it -- a moving camera is a new
  // view every frame. The volume changes only in the classification, so the histograms are the
  // same.
  if (m.histogram_pending || m.histogram_recast) {
    begin("histogram");
    m.record_histogram(cmd, m.histogram_recast ? 1 : 0);  // 1: every block (the stride changed)
    end();
    m.histogram_pending = false;
    m.histogram_recast = false;
  }
  const uint32_t passes = m.passes;
  m.begin_route_choice(cmd);
  if (m.route.probing() && m.route_ts.enabled()) {
    // The probe of the other route (sample_route.h kSampleRouteProbeShare): measured, not applied.
    m.sample_compute = m.route.probe_route() == SampleRouteChooser::kCompute;
    m.route_ts.begin(cmd, m.sample_compute ? "compute_probe" : "raster_probe");
    m.routes_since.probe = m.sample_compute ? 1 : 0;
    m.probe_share_recorded = m.probe_share();
    m.routes_since.probe_share = m.probe_share_recorded;
    m.record_sampling_pass(cmd, ts, iteration * m.max_passes(), m.probe_share_recorded);
    m.route_ts.end(cmd);
  }
  for (uint32_t p = 0; p < passes; ++p) {
    m.sample_compute = m.choose_compute_route(p, passes);
    ++m.route_passes[m.sample_compute ? 1 : 0];
    ++(m.sample_compute ? m.routes_since.compute : m.routes_since.raster);
    const bool timed = m.route.times_passes() && m.route_ts.enabled();
    if (timed)
      m.route_ts.begin(cmd, m.route.comparing() ? (m.sample_compute ? "compute" : "raster")
                                                : (m.sample_compute ? "run_compute" : "run_raster"));
    m.record_sampling_pass(cmd, ts, iteration * m.max_passes() + p);
    if (timed) m.route_ts.end(cmd);
  }

  begin("pyramid");  // Eq. 23
  m.record_pyramid(cmd);
  end();

  // Sect. 5.1, nodes then meshlets (two passes); Sect. 4.4 volume updates.
  begin("classify_nodes");
  vkCmdFillBuffer(cmd, m.counters.get(), 0, offsetof(gpu::CullCounters, selected), 0);
  vkCmdFillBuffer(cmd, m.counters.get(), offsetof(gpu::CullCounters, node_class_count), 20, 0);  // + node_changed
  compute_barrier(cmd);
  m.bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE,
         m.moving && m.classify_coarse_pipe ? m.classify_coarse_pipe : m.classify_pipe, m.set0_sample);
  if (m.nodes_per_group > 0) {
    m.push(cmd, 2);  // a subgroup per node (cull_classify.comp)
    vk::dispatch_rows(cmd, (m.node_count + m.nodes_per_group - 1) / m.nodes_per_group, gpu::kDispatchRow);
  } else {
    m.push(cmd, 0);
    vk::dispatch_rows(cmd, (m.node_count + 63) / 64, gpu::kDispatchRow);
  }
  compute_barrier(cmd);
  end();
  begin("classify_meshlets");
  m.push(cmd, 1);
  vk::dispatch_rows(cmd, (m.meshlet_count + 63) / 64, gpu::kDispatchRow);
  compute_barrier(cmd);
  end();

  m.histogram_pending = true;  // cast at the start of the next iteration of this view

  VkBufferCopy bc{0, 0, sizeof(gpu::CullCounters)};
  vkCmdCopyBuffer(cmd, m.counters.get(), m.counters_host.get(), 1, &bc);
  VkBufferCopy nc{0, 0, 4ull * m.node_count};
  vkCmdCopyBuffer(cmd, m.node_class.get(), m.node_class_host.get(), 1, &nc);
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

void CullLoop::record_draw_list(VkCommandBuffer cmd) {
  Impl& m = *impl_;
  m.bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, m.draw_list_pipe, m.set0_draw);
  vk::dispatch_rows(cmd, (m.meshlet_count + 63) / 64, gpu::kDispatchRow);
}

gpu::CullCounters CullLoop::counters() const {
  gpu::CullCounters c{};
  impl_->counters_host.invalidate();
  std::memcpy(&c, impl_->counters_host.mapped(), sizeof(c));
  // The next iteration's update route (cull_loop_impl.h sampled_fraction).
  if (c.sampled > 0) impl_->sampled_fraction = double(c.sampled) / (double(impl_->width) * impl_->height);
  return c;
}

std::span<const uint32_t> CullLoop::node_classes() const {
  impl_->node_class_host.invalidate();
  return {static_cast<const uint32_t*>(impl_->node_class_host.mapped()), impl_->node_count};
}
uint32_t CullLoop::meshlet_slots() const { return impl_->meshlet_count; }


}  // namespace mds::render::culling
