// The renderer's progressive API (set_view / step / read_image) and out-of-core rendering through
// the streaming cache (issue 4; src/render/streaming/). See renderer.h.
// A step() is one submitted frame: [streaming update: uploads/evictions recorded first] [one
// culling iteration while culling is active] [draw list, pre-pass, draw] [accumulate while
// samples < spp]. The culling results of frame k are read at the start of frame k+1 (one frame
// in flight), so the host never waits for the GPU in the middle of recording, and never for disk.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <functional>
#include <map>
#include <vector>

#include "render/cell_lines.h"
#include "render/renderer_impl.h"
#include "vk/staging.h"

namespace mds::render {

namespace {
double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = q * double(v.size() - 1);
  const size_t lo = size_t(std::floor(pos)), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (pos - double(lo));
}
}  // namespace

// The directory scene of a streamed store: bounds, types, node records; no meshlets/particles.
Status Renderer::Impl::upload_streaming(const SceneData& dir) {
  auto& alloc = ctx->allocator();
  const VkBufferUsageFlags ssbo = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  // Bound whole, as in memory (renderer.cpp): 144 B a node, 932 k nodes on lavapipe.
  if (const uint64_t bytes = dir.nodes.size() * sizeof(gpu::GpuNode); bytes > ctx->limits().maxStorageBufferRange)
    return make_error(Errc::budget, "the node directory needs {} bytes ({} nodes), more than this device's "
                      "maxStorageBufferRange ({} bytes)", bytes, dir.nodes.size(), ctx->limits().maxStorageBufferRange);
  MDS_ASSIGN_OR_RETURN(nodes, vk::Buffer::create(alloc, dir.nodes.size() * sizeof(gpu::GpuNode), ssbo,
                                                 vk::MemoryIntent::device_local, "node directory"));
  MDS_ASSIGN_OR_RETURN(types, vk::Buffer::create(alloc, dir.types.size() * sizeof(gpu::GpuType), ssbo,
                                                 vk::MemoryIntent::device_local, "type table"));
  streaming_gpu::NodePool& pool = cache->pool();
  meshlets_h = pool.meshlets();
  particles_h = pool.particles();
  radii_h = pool.radii();
  property_h = pool.property();
  color_h = pool.color();
  meshlet_class_h = pool.meshlet_class();
  MDS_TRY(create_draw_buffers(pool.meshlet_slots()));
  MDS_ASSIGN_OR_RETURN(vk::StagingRing ring, vk::StagingRing::create(*ctx));
  MDS_TRY(ring.upload_span(nodes, 0, std::span<const gpu::GpuNode>(dir.nodes)));
  std::vector<gpu::GpuType> type_table = dir.types;
  set_type_colors(type_table, settings.type_colors_srgb);
  MDS_TRY(ring.upload_span(types, 0, std::span<const gpu::GpuType>(type_table)));
  MDS_TRY(ring.flush());
  upload_bytes = ring.bytes_uploaded();
  return {};
}

Result<std::unique_ptr<Renderer>> Renderer::create_streaming(vk::Context& ctx, const store::StoreReader& reader,
                                                             const RenderSettings& settings,
                                                             const StreamSettings& stream) {
  if (settings.width == 0 || settings.height == 0 || settings.width > 16384 || settings.height > 16384)
    return make_error(Errc::invalid_argument, "image size {}x{} outside 1..16384", settings.width, settings.height);
  if (settings.spp == 0) return make_error(Errc::invalid_argument, "--spp must be >= 1");
  const store::FileHeader& h = reader.header();
  std::vector<float> radii;
  for (const auto& t : reader.types()) radii.push_back(t.radius);
  const bool ppr = (h.flags & store::kFlagPerParticleRadius) != 0;
  SceneData dir = begin_scene({h.bounds_min[0], h.bounds_min[1], h.bounds_min[2]},
                              {h.bounds_max[0], h.bounds_max[1], h.bounds_max[2]}, radii, ppr, h.radius_min,
                              h.radius_max);

  std::unique_ptr<Renderer> r(new Renderer());
  r->impl_ = std::make_unique<Impl>();
  Impl& m = *r->impl_;
  m.ctx = &ctx;
  m.settings = settings;
  MDS_ASSIGN_OR_RETURN(m.mesh_path, use_mesh_sprites(ctx, settings.mesh_shaders));
  m.reader = &reader;
  m.origin = dir.origin;
  m.bounds = dir.bounds;
  m.clip_bounds = with_cell(m.bounds, settings.cell);
  // The sprite records do not bound the pool: a draw list with more particles than they hold is
  // drawn in chunks (create_draw_buffers); the pool's own buffers do (NodePool::create).
  StreamSettings pool_stream = stream;
  pool_stream.colors = settings.color_by.by_color();  // the pool carries colours only where they are drawn
  MDS_ASSIGN_OR_RETURN(m.cache, streaming_gpu::StreamCache::create(ctx, reader, pool_stream, dir.origin));
  dir.nodes = m.cache->directory();
  m.meshlet_count = m.cache->pool().meshlet_slots();
  m.particle_count = h.particle_count;
  m.max_meshlet = m.cache->max_meshlet_particles();
  m.flags = ppr ? gpu::kFramePerParticleRadius : 0u;
  m.radius_min = h.radius_min;
  m.radius_max = h.radius_max;
  m.has_property = (h.flags & store::kFlagProperty) != 0;
  m.property_min = h.property_min;
  m.property_max = h.property_max;
  m.has_color = (h.flags & store::kFlagColor) != 0;
  MDS_TRY(check_color_by(settings.color_by, m.has_property, m.has_color));
  MDS_TRY(m.upload_streaming(dir));
  MDS_TRY(m.create_frame_resources());
  if (settings.cull) {
    culling::DensityVolume vol;
    if (settings.density) {
      vol = *settings.density;
    } else {
      MDS_ASSIGN_OR_RETURN(vol, culling::density_from_store(reader, dir.origin));
    }
    m.cache->kept_density(vol);  // with --slice or --threshold: what the nodes keep
    culling::CullScene cs;
    cs.origin = dir.origin;
    cs.meshlet_slots = m.meshlet_count;
    cs.node_count = uint32_t(dir.nodes.size());
    cs.max_meshlet_particles = m.max_meshlet;
    cs.per_particle_radius = ppr;
    cs.radius_min = h.radius_min;
    cs.radius_max = h.radius_max;
    cs.footprint_radius = smallest_radius(dir);
    cs.node_density = true;  // issue 4: O updates subtract whole nodes, resident or not
    cs.node_extent = culling::kNodeExtentStreaming;  // node classes decide the reads
    cs.voxel_first = m.cache->voxel_first();
    cs.voxel_refs = m.cache->voxel_refs();
    MDS_TRY(m.create_cull(cs, vol));
  }
  return r;
}

void Renderer::Impl::write_frame_uniforms(const Camera& camera, uint32_t sample, uint32_t extra_flags,
                                          bool all_meshlets) {
  const uint32_t w = settings.width, h = settings.height;
  const double aspect = double(w) / double(h);
  const glm::dvec2 jitter_px = halton_jitter(sample);
  const glm::dmat4 proj = projection_matrix(camera, aspect, {2.0 * jitter_px.x / w, 2.0 * jitter_px.y / h});
  gpu::FrameUniforms fu{};
  const glm::dmat4 view = view_matrix(camera, origin);
  fu.view = glm::mat4(view);
  fu.proj = glm::mat4(proj);
  fu.inv_proj = glm::mat4(glm::inverse(proj));
  fu.viewport = glm::vec4(float(w), float(h), 1.0f / float(w), 1.0f / float(h));
  fu.radius_range = glm::vec4(radius_min, radius_max - radius_min, float(camera.near), float(camera.far));
  uint32_t color_flag = 0;
  if (settings.color_by.by_color()) {  // the particles' own colours (store kFlagColor)
    color_flag = gpu::kFrameColorParticle;
  } else if (settings.color_by.by_property()) {  // colour by the per-particle property (render/colormap.h)
    const glm::dvec2 range = color_range();
    const glm::dvec2 map = property_color_map(property_min, property_max, range.x, range.y);
    fu.color_plane = glm::vec4(float(map.x), 0.0f, 0.0f, float(map.y));
    color_flag = gpu::kFrameColorMap | gpu::kFrameColorProperty;
  } else if (!settings.color_by.by_type()) {  // colour by coordinate (render/colormap.h)
    const glm::dvec2 range = color_range();
    fu.color_plane = glm::vec4(color_plane(view, origin, settings.color_by.axis, range.x, range.y));
    color_flag = gpu::kFrameColorMap;
  }
  if (color_flag)
    for (uint32_t k = 0; k < gpu::kColormapSamples; ++k)
      fu.colormap[k] = glm::vec4(glm::vec3(colormap_sample(settings.color_by.map, k)), 0.0f);
  fu.counts = glm::uvec4(meshlet_count, max_meshlet,
                         flags | extra_flags | color_flag | (camera.ortho ? gpu::kFrameOrtho : 0u), sample);
  // The particle occlusion test (particle_occlusion.h) once the view's culling has stopped: the
  // pyramid is then final and the frame draws the potentially visible set.
  const bool occlusion_test = settings.particle_occlusion && cull && !cull_active && cull_iteration > 0 &&
                              !all_meshlets && cull->width() == w && cull->height() == h;
  particle_test = occlusion_test && prepass_occ_pipe;
  if (cull)
    fu.occlusion = glm::vec4(float(cull->settings().c_occ), float(cull->settings().c_medium),
                             occlusion_test ? float(cull->pyramid_levels()) : 0.0f, 0.0f);
  if (ao_active()) fu.ao = glm::vec4(float(settings.ao_radius), float(settings.ao_strength), 0.0f, 0.0f);
  cell_uniforms(settings.cell, origin, settings.cell_color_srgb, settings.cell_width_px, fu.cell);
  std::memcpy(frame_ubo.mapped(), &fu, sizeof(fu));
  frame_ubo.flush();
}

// Sum of the passes of the frame that completed last (0 when none was timed).
Result<double> Renderer::Impl::collect_frame_ms() {
  std::map<std::string, size_t> before;
  for (const auto& [name, v] : timestamps.samples()) before[name] = v.size();
  MDS_TRY(timestamps.collect());
  double sum = 0.0;
  FrameGpu g;
  for (const auto& [name, v] : timestamps.samples())
    for (size_t i = before.count(name) ? before[name] : 0; i < v.size(); ++i) {
      sum += v[i];
      g.passes[name] += v[i];
    }
  if (!g.passes.empty()) {
    g.ms = sum;
    // Paced sampling (sample_pacer.h): the frame in flight, now collected, ran iteration_passes
    // sampling passes: this view's pass time, recorded for the pacer's reference when at rest.
    if (const auto it = g.passes.find("sample"); it != g.passes.end() && iteration_passes > 0) {
      view_pass_ms = it->second / double(iteration_passes);
      if (!iteration_moving) sample_pacer.observe(view_pass_ms);
    }
    last_gpu = std::move(g);
  }
  return sum;
}

// The culling iteration of the previous frame completed: counters, convergence (Sect. 5.3).
void Renderer::Impl::after_iteration() {
  // A failed timestamp read only leaves the sampling route as it was (cull_loop.h).
  (void)cull->collect_route_timings();
  const gpu::CullCounters c = cull->counters();
  view_cull.changed_per_iteration.push_back(c.changed);
  view_cull.culled_per_iteration.push_back(c.class_count[MDS_CULL_CLASS_O]);
  view_cull.class_counts.assign(c.class_count, c.class_count + 4);
  view_cull.node_class_counts.assign(c.node_class_count, c.node_class_count + 4);
  view_cull.budget_per_iteration.push_back(iteration_budget);
  view_cull.selected_per_iteration.push_back(c.selected);
  view_sampled = view_sampled || c.selected > 0;
  if (iteration_hook) iteration_hook(cull_iteration);
  ++cull_iteration;
  view_passes += iteration_passes;
  // Streaming: node classes drive the cache, so they must be stable too. Quiet is counted in
  // sampling passes: a paced view needs as many quiet passes as an unpaced one.
  const bool still = c.changed == 0 && (!cache || c.node_changed == 0);
  quiet = still ? quiet + iteration_passes : 0;
  if (quiet >= std::max(1u, cull->settings().converge_iterations) * std::max(1u, iteration_full)) {
    cull_active = false;
    culling_converged = true;
    view_cull.converged = true;
    view_cull.iterations_to_converge = cull_iteration;
    view_cull.samples_to_converge = view_passes;
    view_cull.time_to_converge_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - view_t0).count();
  } else if (cull_iteration >= std::max(1u, cull->settings().max_iterations)) {
    cull_active = false;  // cap reached: keep the classes, not converged
  }
  if (cache) cache->set_classes(cull->node_classes(), cull_iteration >= std::max(1u, cull->settings().converge_iterations));
}

Status Renderer::set_view(const Camera& camera_in) {
  Impl& m = *impl_;
  Camera camera = camera_in;
  fit_clip_planes(camera, m.clip_bounds);
  if (m.has_view && !m.view_stale && identical_cameras(camera, m.view_camera)) return {};
  m.view_stale = false;
  MDS_TRY(m.slot.wait());  // the frame in flight belongs to the old view
  // Its timestamps, before the pool is replaced: the next FrameReport reports them.
  MDS_ASSIGN_OR_RETURN(double old_view_ms, m.collect_frame_ms());
  m.unreported_gpu_ms += old_view_ms;
  // Its culling iteration still tells the cache what is occluded (the view did not mature), and
  // its sampling passes' times the route choice (a moving camera's views last one frame each).
  if (m.pending_iteration) (void)m.cull->collect_route_timings();
  if (m.pending_iteration && m.cache) m.cache->set_classes(m.cull->node_classes(), false);
  m.pending_iteration = false;
  MDS_ASSIGN_OR_RETURN(m.timestamps, vk::TimestampPool::create(*m.ctx, m.timestamp_capacity()));
  m.view_camera = camera;
  m.has_view = true;
  m.samples = 0;
  m.view_coverage = -1;  // the next frame probes the new view's coverage (resolve choice)
  m.coverage_probe_pending = false;
  m.quiet = 0;
  m.culling_converged = false;
  m.cull_iteration = 0;
  m.view_sampled = false;
  m.view_pass_ms = -1.0;
  m.view_passes = 0;
  m.sample_pacer.new_view();
  m.view_cull = CullStats{};
  m.frame_gpu_ms.clear();
  m.frame_wall_ms.clear();
  m.view_t0 = std::chrono::steady_clock::now();
  m.view_first_frame = m.frame_index;
  m.view_complete_frames = 0;
  m.view_complete_ms = -1.0;
  if (m.cache) m.cache->set_view(camera, double(m.settings.width) / double(m.settings.height), m.path_next);
  m.complete = !m.cache;
  if (m.cull) {
    const uint32_t live = m.cache ? uint32_t(m.cache->live_meshlets()) : m.meshlet_count;
    MDS_TRY(m.cull->prepare_view(camera, live));  // reset recorded by the next step()'s iteration
    m.cull_active = true;
  }
  return {};
}

Result<FrameReport> Renderer::step() {
  Impl& m = *impl_;
  if (!m.has_view) return make_error(Errc::internal, "Renderer::step() before set_view()");
  if (m.targets_lost)
    return make_error(Errc::budget, "Renderer::step(): the resize to {}x{} failed; resize again first", m.settings.width,
                      m.settings.height);
  if (m.view_stale) MDS_TRY(set_view(m.view_camera));  // resized: restart the view at the new size
  const auto t0 = std::chrono::steady_clock::now();
  FrameReport rep;
  rep.frame = m.frame_index;
  MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, m.slot.begin());  // waits for the previous frame
  const auto t_begun = std::chrono::steady_clock::now();
  rep.wait_ms = std::chrono::duration<double, std::milli>(t_begun - t0).count();
  MDS_ASSIGN_OR_RETURN(rep.gpu_ms, m.collect_frame_ms());
  if (rep.gpu_ms > 0.0) m.frame_gpu_ms.push_back(rep.gpu_ms);
  // Collected by finish() (this view) or set_view() (the previous view's last frame).
  rep.gpu_ms += m.unreported_gpu_ms;
  m.unreported_gpu_ms = 0.0;
  if (m.pending_iteration) m.after_iteration();
  m.pending_iteration = false;
  m.destroyer.collect(m.frame_index);

  if (m.cache) {
    const auto t_cache = std::chrono::steady_clock::now();
    // The pool's transfers (evictions, uploads) are the frame's first GPU work: timed as pass
    // "upload", so the timestamp pool is reset here rather than by record_pass.
    m.timestamps.reset(cmd);
    m.timestamps_reset = true;
    m.timestamps.begin(cmd, "upload");
    MDS_ASSIGN_OR_RETURN(streaming_gpu::CacheFrame cf, m.cache->update(cmd, m.frame_index));
    if (!cf.left_out.empty()) {
      // Read and emptied by the slices: the classification skips them from now on (4 bytes a node).
      for (const uint32_t i : cf.left_out)
        vkCmdUpdateBuffer(cmd, m.nodes.get(), i * sizeof(gpu::GpuNode) + offsetof(gpu::GpuNode, flags),
                          sizeof(uint32_t), &m.cache->directory()[i].flags);
      vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    }
    m.timestamps.end(cmd);
    rep.cache_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_cache).count();
    rep.nodes_uploaded = cf.nodes_uploaded;
    rep.bytes_uploaded = cf.bytes_uploaded;
    rep.frame_hits = cf.hits;
    rep.frame_misses = cf.misses;
    rep.reads_requested = cf.reads_requested;
    rep.upload_regions = cf.copy_regions;
    rep.upload_stall = cf.upload_stall;
    rep.budget_exhausted = cf.exhausted;
    rep.wanted = std::move(cf.wanted);
    rep.wanted_hit = std::move(cf.wanted_resident);
    m.complete = cf.complete;
    if (cf.nodes_uploaded > 0) {  // new data: refine again
      m.samples = 0;
      // ... and probe the coverage again (resolve choice): a cold cache's first frame covers
      // nothing, so the view's first probe alone would keep the list on a close-up. A probe still
      // in flight counted the old data: dropped.
      m.view_coverage = -1;
      m.coverage_probe_pending = false;
      if (m.cull && m.cull_iteration < std::max(1u, m.cull->settings().max_iterations)) {
        m.cull_active = true;
        m.quiet = 0;
        m.culling_converged = false;
      }
    }
  }
  m.pending_iteration = m.cull && m.cull_active;
  // At most a share of what is resident while the pool fills (cull_loop.h); a view that wants
  // more than the pool holds draws the whole budget in its first sampled iteration
  // (docs/streaming.md, "Occluder share of a filling cache").
  if (m.pending_iteration && m.cache)
    m.cull->set_resident_meshlets(uint32_t(m.cache->live_meshlets()),
                                  m.cache->filling() && (m.cache->holds_wanted() || m.view_sampled) &&
                                      !rep.budget_exhausted);
  if (m.pending_iteration) {
    // Sampling passes of this iteration: one while moving, else the configured passes, paced.
    m.iteration_moving = m.moving;
    m.iteration_full = m.moving ? 1u : std::max(1u, m.settings.cull_settings.samples_per_iteration);
    m.iteration_passes = m.iteration_full;
    if (!m.moving && m.settings.pace_sampling)
      m.iteration_passes = m.sample_pacer.passes(m.iteration_full, m.view_pass_ms);
    m.cull->set_samples_per_iteration(m.iteration_passes);
    m.iteration_budget = m.cull->pass_budget();
  }
  const bool accumulate = m.samples < m.settings.spp;
  m.write_frame_uniforms(m.view_camera, m.samples);
  m.record_pass(cmd, m.samples == 0, accumulate);
  MDS_TRY(m.slot.submit(m.ctx->queue()));
  m.rendered = true;  // read_last_depth(): this frame's depth
  ++m.frame_index;
  if (accumulate) ++m.samples;

  rep.samples = m.samples;
  rep.accumulated = accumulate;
  rep.culling_active = m.pending_iteration;
  if (m.cull) {
    const culling::CullLoop::SampleRoutes routes = m.cull->take_sample_routes();
    rep.sample_passes_raster = routes.raster;
    rep.sample_passes_compute = routes.compute;
    rep.sample_probe = routes.probe;
    rep.sample_probe_share = routes.probe_share;
    rep.sample_compared_ms_raster = m.cull->sample_route_ms(culling::SampleRoute::raster);
    rep.sample_compared_ms_compute = m.cull->sample_route_ms(culling::SampleRoute::compute);
  }
  rep.culling_converged = m.culling_converged;
  rep.complete = m.complete;
  rep.converged = (!m.cull || m.culling_converged) && m.complete;
  rep.settled = (!m.cull || !m.cull_active) && m.complete;
  if (m.cull) {
    const gpu::CullCounters c = m.cull->counters();
    for (int k = 0; k < 4; ++k) {
      rep.class_counts[k] = m.view_cull.class_counts.size() == 4 ? m.view_cull.class_counts[k] : 0;
      rep.node_class_counts[k] = m.cull_iteration > 0 ? c.node_class_count[k] : 0;
    }
  }
  const auto t_end = std::chrono::steady_clock::now();
  rep.wall_ms = std::chrono::duration<double, std::milli>(t_end - t0).count();
  m.frame_wall_ms.push_back(rep.wall_ms);
  if (m.cache && m.complete && m.view_complete_frames == 0) {
    m.view_complete_frames = uint32_t(m.frame_index - m.view_first_frame);  // frame_index counts this frame
    m.view_complete_ms = std::chrono::duration<double, std::milli>(t_end - m.view_t0).count();
  }
  return rep;
}

Status Renderer::Impl::resize(uint32_t w, uint32_t h) {
  if (w == 0 || h == 0 || w > 16384 || h > 16384)
    return make_error(Errc::invalid_argument, "resize to {}x{}: outside 1..16384", w, h);
  if (w == settings.width && h == settings.height && !targets_lost) return {};
  MDS_TRY(slot.wait());  // the frame in flight uses the old targets
  // Its culling iteration still tells the cache what is occluded (as set_view does).
  if (pending_iteration && cache && cull) cache->set_classes(cull->node_classes(), false);
  pending_iteration = false;
  settings.width = w;
  settings.height = h;
  targets_lost = true;  // until every target and descriptor of the new size is in place
  // Replaces (and releases) the old targets; the visibility route's buffer must fit the range.
  if (Status st = create_targets(); !st.ok())
    return make_error(st.error().code, "resize to {}", st.error().message);
  if (!vis_route) set.write_storage_image(gpu::kBindColorImage, color.view());
  write_accumulation_descriptors();
  // The accumulation may have moved between buffer and image (maxStorageBufferRange).
  if (accum_in_buffer != accum_pipe_in_buffer) MDS_TRY(create_accumulate_pipeline());
  set.write_buffer(gpu::kBindVisibility, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, visibility.get());
  if (cull) MDS_TRY(cull->resize(w, h));
  write_occlusion_descriptor();
  targets_lost = false;
  samples = 0;
  rendered = false;  // read_last_depth(): no frame at this size yet
  if (has_view) view_stale = true;
  return {};
}

Status Renderer::resize(uint32_t width, uint32_t height) { return impl_->resize(width, height); }

// A culling setting changed in place (set_c_occ, set_coverage): the frame in flight finishes
// with the old one, its culling iteration still tells the cache what is occluded (as set_view
// does), `apply` changes the loop, and the view restarts at the next step().
Status Renderer::Impl::change_culling(const std::function<void(culling::CullLoop&)>& apply) {
  MDS_TRY(slot.wait());
  if (cull) {
    if (pending_iteration && cache) cache->set_classes(cull->node_classes(), false);
    pending_iteration = false;
    apply(*cull);
    if (has_view) view_stale = true;
  }
  return {};
}

Status Renderer::set_coverage(culling::Coverage coverage) {
  Impl& m = *impl_;
  if (coverage == m.settings.cull_settings.coverage) return {};
  MDS_TRY(m.change_culling([&](culling::CullLoop& loop) { loop.set_coverage(coverage); }));
  m.settings.cull_settings.coverage = coverage;
  return {};
}

Status Renderer::set_c_occ(double c_occ) {
  Impl& m = *impl_;
  if (!(c_occ > 0.0 && c_occ < 1.0)) return make_error(Errc::invalid_argument, "C_occ {}: expected (0, 1)", c_occ);
  if (c_occ == m.settings.cull_settings.c_occ) return {};
  MDS_TRY(m.change_culling([&](culling::CullLoop& loop) { loop.set_c_occ(c_occ); }));
  m.settings.cull_settings.c_occ = c_occ;
  return {};
}

Status Renderer::finish() {
  Impl& m = *impl_;
  MDS_TRY(m.slot.wait());
  MDS_ASSIGN_OR_RETURN(double ms, m.collect_frame_ms());
  if (ms > 0.0) {
    m.frame_gpu_ms.push_back(ms);
    m.unreported_gpu_ms += ms;
  }
  return {};
}

FrameGpu Renderer::last_frame_gpu() const { return impl_->last_gpu; }

static_assert(Renderer::kPathNextViews == uint32_t(streaming_gpu::StreamCache::kLookaheadFrames));

void Renderer::set_path_next(std::span<const Camera> next) {
  Impl& m = *impl_;
  m.path_next.assign(next.begin(), next.end());
  for (Camera& c : m.path_next) fit_clip_planes(c, m.clip_bounds);
}

void Renderer::set_motion(bool moving, double sample_share) {
  Impl& m = *impl_;
  if (m.cull) m.cull->set_moving(moving, sample_share);
  m.moving = moving;  // step() sets the iteration's sampling passes from it (one while moving)
}

Status Renderer::set_ambient_occlusion(double radius, double strength) {
  Impl& m = *impl_;
  if (!(radius >= 0.0 && strength >= 0.0 && std::isfinite(radius) && std::isfinite(strength)))
    return make_error(Errc::invalid_argument, "ambient occlusion radius {} strength {}: expected finite values >= 0",
                      radius, strength);
  if (radius == m.settings.ao_radius && strength == m.settings.ao_strength) return {};
  m.settings.ao_radius = radius;
  m.settings.ao_strength = strength;
  m.samples = 0;  // the next frame clears the accumulation
  return {};
}

Status Renderer::set_color_by(const ColorBy& c) {
  Impl& m = *impl_;
  MDS_TRY(check_color_by(c, m.has_property, m.has_color));
  if (m.cache && c.by_color() && !m.cache->pool().layout().color)
    return make_error(Errc::unsupported, "the streaming pool holds no colours: re-create the renderer to draw them");
  m.settings.color_by = c;
  m.samples = 0;  // the next frame clears the accumulation
  return {};
}

Status Renderer::set_cell(const std::optional<SimulationCell>& cell) {
  Impl& m = *impl_;
  if (cell && !cell->finite())
    return make_error(Errc::invalid_argument, "simulation cell with a non-finite value: {}", describe(*cell));
  m.settings.cell = cell;
  m.clip_bounds = with_cell(m.bounds, cell);
  if (cell && m.cell_pipe == VK_NULL_HANDLE) MDS_TRY(m.create_cell_pipeline());
  m.samples = 0;  // the next frame clears the accumulation
  if (m.has_view) {  // the clip planes fitted again: the view restarts at the next step()
    m.view_camera.near = m.view_camera.far = 0.0;
    m.view_stale = true;
  }
  return {};
}

Status Renderer::set_spp(uint32_t spp) {
  if (spp == 0) return make_error(Errc::invalid_argument, "spp {}: expected >= 1", spp);
  impl_->settings.spp = spp;
  return {};
}
uint32_t Renderer::width() const { return impl_->settings.width; }
uint32_t Renderer::height() const { return impl_->settings.height; }

Result<FrameImage> Renderer::read_image() {
  Impl& m = *impl_;
  if (m.targets_lost) return make_error(Errc::budget, "Renderer::read_image(): the last resize failed; resize again first");
  MDS_TRY(m.slot.wait());
  FrameImage img;
  img.width = m.settings.width;
  img.height = m.settings.height;
  img.rgba.assign(size_t(img.width) * img.height * 4, 0.0f);
  if (m.samples == 0) return img;
  MDS_ASSIGN_OR_RETURN(img.rgba, m.read_average(m.samples));
  return img;
}

RenderStats Renderer::stats() const {
  const Impl& m = *impl_;
  RenderStats s;
  s.device = m.ctx->info().name;
  s.mesh_sprites = m.mesh_path;
  s.visibility_route = m.vis_route;
  s.ambient_occlusion = m.ao_active();
  s.accumulation_buffer = m.accum_in_buffer;
  s.covered_pixel_list = m.covered_list && m.last_resolve_listed;
  s.covered_fraction = m.covered_fraction(m.settings.width, m.settings.height);
  s.sprite_chunks = m.sprite_chunks;
  s.particles = m.particle_count;
  s.meshlets = m.cache ? m.cache->live_meshlets() : m.meshlet_count;
  s.spp = m.settings.spp;
  s.width = m.settings.width;
  s.height = m.settings.height;
  for (const auto& [name, v] : m.timestamps.samples()) {
    const double med = vk::median(v);
    s.pass_ms_median[name] = med;
    s.frame_ms_median += med;
  }
  s.upload_bytes = m.upload_bytes;
  s.device_bytes = m.ctx->allocator().peak(vk::MemoryIntent::device_local);
  s.near = m.view_camera.near;
  s.far = m.view_camera.far;
  s.cull = m.view_cull;
  if (m.cull) {
    s.cull.enabled = true;
    s.cull.iterations = m.cull_iteration;
    s.cull.samples = m.view_passes;
    s.cull.samples_per_iteration = m.cull->samples_per_iteration();
    s.cull.bins = m.cull->bins();
    s.cull.sample_passes_compute = m.cull->sample_route_passes(culling::SampleRoute::compute);
    s.cull.sample_passes_raster = m.cull->sample_route_passes(culling::SampleRoute::raster);
    s.cull.sample_ms_compute = m.cull->sample_route_ms(culling::SampleRoute::compute);
    s.cull.sample_ms_raster = m.cull->sample_route_ms(culling::SampleRoute::raster);
    s.cull.shared_box_tests = m.cull->shared_box_tests();
    s.cull.node_per_subgroup = m.cull->node_per_subgroup();
    s.cull.shared_cells = m.cull->shared_cells();
    s.cull.budget = m.cull->budget();
    if (s.cull.class_counts.size() == 4) s.cull.meshlets_culled = s.cull.class_counts[MDS_CULL_CLASS_O];
  }
  if (m.cache) {
    s.cache = m.cache->stats();
    s.cache.scratch_bytes = m.scratch_bytes;
    s.cache.frames_to_complete = m.view_complete_frames;
    s.cache.ms_to_complete = m.view_complete_ms;
  }
  s.frames = uint32_t(m.frame_wall_ms.size());
  s.frame_wall_ms_p50 = percentile(m.frame_wall_ms, 0.5);
  s.frame_wall_ms_p99 = percentile(m.frame_wall_ms, 0.99);
  return s;
}

const Bounds& Renderer::bounds() const { return impl_->bounds; }
const Bounds& Renderer::clip_bounds() const { return impl_->clip_bounds; }
glm::dvec2 Renderer::color_range() const { return impl_->color_range(); }
glm::dvec2 Renderer::Impl::color_range() const {
  const ColorBy& c = settings.color_by;
  if (c.by_type()) return glm::dvec2(0.0);
  if (c.lo < c.hi) return glm::dvec2(c.lo, c.hi);
  if (c.by_property()) return property_default_range(property_min, property_max);
  double lo = bounds.min[c.axis], hi = bounds.max[c.axis];
  if (!(lo < hi)) {  // all centres in one plane: t = 0.5 for every particle
    const double pad = std::max(1e-9 * glm::length(bounds.max - bounds.min), 1e-12 * (1.0 + std::abs(lo)));
    lo -= pad;
    hi += pad;
  }
  return glm::dvec2(lo, hi);
}
std::vector<uint64_t> Renderer::node_device_bytes() const {
  return impl_->cache ? impl_->cache->node_device_bytes() : std::vector<uint64_t>{};
}
Result<std::vector<uint64_t>> Renderer::node_device_bytes_kept() const {
  if (!impl_->cache) return std::vector<uint64_t>{};
  return impl_->cache->node_device_bytes_kept();
}
std::vector<uint8_t> Renderer::resident_nodes() const {
  if (!impl_->cache) return {};
  const auto& pool = impl_->cache->pool();
  std::vector<uint8_t> r(impl_->cache->directory().size());
  for (uint32_t i = 0; i < r.size(); ++i) r[i] = pool.resident(i) ? 1 : 0;
  return r;
}
std::shared_ptr<const streaming::PriorView> Renderer::prior_view() const {
  if (!impl_->cache) return nullptr;
  return std::make_shared<const streaming::PriorView>(impl_->cache->prior_view());
}
std::vector<NodeLogEntry> Renderer::node_log() const {
  if (!impl_->cache) return {};
  return impl_->cache->node_log();
}
bool Renderer::streaming() const { return impl_->cache != nullptr; }

// Headless render with a budget: frames until the view has converged with every wanted node
// resident (culling converged or capped, cache complete), then spp samples of that state (an
// upload restarts the accumulation, so the image never mixes incomplete frames), and at least
// kTimingFrames frames that recorded no culling iteration with the cache complete: the frames
// "after convergence" of the stats (past spp they draw with weight 0, so the image keeps its spp
// samples). A frame's GPU time is collected when the next frame begins (or after the loop).
Result<FrameImage> Renderer::render_streaming(const Camera& camera, RenderStats* stats) {
  Impl& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  m.has_view = false;  // always a fresh view
  MDS_TRY(set_view(camera));
  constexpr uint64_t kMaxFrames = 1000000;  // a guard against a cache that never completes
  std::vector<double> during, after;
  std::map<std::string, std::vector<double>> after_passes;
  bool have_prev = false, prev_after = false;  // the frame whose GPU time comes next
  auto attribute = [&](double ms) {
    if (!have_prev || ms <= 0.0) return;
    (prev_after ? after : during).push_back(ms);
    if (prev_after)
      for (const auto& [name, v] : m.last_gpu.passes) after_passes[name].push_back(v);
  };
  uint32_t settled_run = 0;  // consecutive frames of the settled state
  for (uint64_t f = 0;; ++f) {
    MDS_ASSIGN_OR_RETURN(FrameReport rep, step());
    if (f > 0) attribute(rep.gpu_ms);  // the previous frame's (the first step's is the old view's)
    prev_after = !rep.culling_active && rep.complete && rep.nodes_uploaded == 0;
    have_prev = true;
    settled_run = prev_after ? settled_run + 1 : 0;
    const bool settled = rep.complete && !m.cull_active && !m.pending_iteration;
    if (settled && rep.samples >= m.settings.spp && (!m.cull || settled_run >= kTimingFrames)) break;
    if (f >= kMaxFrames) return make_error(Errc::internal, "streaming render did not settle in {} frames", kMaxFrames);
  }
  MDS_TRY(m.slot.wait());
  MDS_ASSIGN_OR_RETURN(double last_ms, m.collect_frame_ms());
  if (last_ms > 0.0) m.frame_gpu_ms.push_back(last_ms);
  attribute(last_ms);
  MDS_ASSIGN_OR_RETURN(FrameImage img, read_image());
  m.rendered = true;
  if (stats) {
    *stats = this->stats();
    MDS_TRY(m.read_sprite_counts(*stats));
    stats->wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    stats->frames = uint32_t(m.frame_wall_ms.size());
    if (m.cull) {
      stats->cull.frame_ms_after_convergence = vk::median(after);
      stats->cull.frame_ms_during_culling = vk::median(during);
      stats->cull.pass_ms_after_convergence.clear();
      for (const auto& [name, v] : after_passes) stats->cull.pass_ms_after_convergence[name] = vk::median(v);
    }
  }
  return img;
}

}  // namespace mds::render
