// The probabilistic occlusion culling loop on the GPU (paper 000, Sect. 3-5, Algorithm 1).
// See cull_loop.h; shaders: shaders/cull_*.comp. The occlusion sampling pass and its two routes
// live in cull_sampling.cpp, the loop's state in cull_loop_impl.h.
#include "render/culling/cull_loop.h"

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <iterator>

#include "culling/normal_cdf_table.h"
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

Status CullLoop::Impl::create_buffers(const CullScene& s, const DensityVolume& vol) {
  auto& alloc = ctx->allocator();
    auto make = [&](vk::Buffer& b, uint64_t bytes, const char* what, VkBufferUsageFlags extra = 0) -> Status {
    if (bytes > ctx->limits().maxStorageBufferRange)
      return make_error(Errc::budget, "culling: {} need {} bytes, more than maxStorageBufferRange ({})", what, bytes,
                        ctx->limits().maxStorageBufferRange);
    MDS_ASSIGN_OR_RETURN(b, vk::Buffer::create(alloc, std::max<uint64_t>(bytes, 16), kSsbo | extra,
                                               vk::MemoryIntent::device_local, what));
    return {};
  };
  MDS_TRY(create_pixel_buffers());
  MDS_TRY(make(volume, vol.counts.size() * 4, "density volume"));
  MDS_TRY(make(volume_init, vol.counts.size() * 4, "density volume (initial)"));
  MDS_TRY(make(meshlet_voxel_first, s.voxel_first.size() * 4, "voxel list index"));
  MDS_TRY(make(voxel_refs, s.voxel_refs.size() * 8, "voxel lists"));
  if (meshlet_class == VK_NULL_HANDLE) {
    MDS_TRY(make(own_meshlet_class, uint64_t(meshlet_count) * 4, "meshlet classes"));
    meshlet_class = own_meshlet_class.get();
  }
  MDS_TRY(make(node_class, uint64_t(node_count) * 4, "node classes"));
  MDS_TRY(make(counters, sizeof(gpu::CullCounters), "cull counters"));
  static constexpr float kNormalCdf[] = {MDS_CULL_NORMAL_CDF_TABLE_VALUES};
  static_assert(std::size(kNormalCdf) == MDS_CULL_NORMAL_TABLE_SIZE);
  MDS_TRY(make(normal_cdf, sizeof(kNormalCdf), "normal CDF table"));
  MDS_TRY(make(occluder_list, sizeof(gpu::DrawListHeader) + 4ull * meshlet_count, "occluder list",
               VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT));
  MDS_ASSIGN_OR_RETURN(counters_host, vk::Buffer::create(alloc, sizeof(gpu::CullCounters),
                                                         VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                         vk::MemoryIntent::readback, "cull counters (host)"));
  MDS_ASSIGN_OR_RETURN(node_class_host, vk::Buffer::create(alloc, std::max<uint64_t>(4ull * node_count, 16),
                                                           VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                           vk::MemoryIntent::readback, "node classes (host)"));
  MDS_ASSIGN_OR_RETURN(cull_ubo, vk::Buffer::create(alloc, sizeof(gpu::CullUniforms), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                                    vk::MemoryIntent::upload, "cull uniforms"));
  MDS_ASSIGN_OR_RETURN(frame_ubo, vk::Buffer::create(alloc, sizeof(gpu::FrameUniforms),
                                                     VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, vk::MemoryIntent::upload,
                                                     "sampling frame uniforms"));
  std::vector<uint16_t> idx(6 * size_t(max_meshlet));
  for (uint32_t i = 0; i < max_meshlet; ++i) {
    const uint16_t b = uint16_t(4 * i);
    const uint16_t q[6] = {b, uint16_t(b + 1), uint16_t(b + 2), uint16_t(b + 2), uint16_t(b + 1), uint16_t(b + 3)};
    std::memcpy(&idx[6 * i], q, sizeof(q));
  }
  MDS_ASSIGN_OR_RETURN(indices, vk::Buffer::create(alloc, idx.size() * 2,
                                                   VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                   vk::MemoryIntent::device_local, "sampling billboard indices"));
  MDS_ASSIGN_OR_RETURN(vk::StagingRing ring, vk::StagingRing::create(*ctx));
  MDS_TRY(ring.upload_span(volume_init, 0, std::span<const int32_t>(vol.counts)));
  MDS_TRY(ring.upload_span(meshlet_voxel_first, 0, std::span<const uint32_t>(s.voxel_first)));
  MDS_TRY(ring.upload_span(voxel_refs, 0, std::span<const glm::uvec2>(s.voxel_refs)));
  MDS_TRY(ring.upload_span(indices, 0, std::span<const uint16_t>(idx)));
  MDS_TRY(ring.upload_span(normal_cdf, 0, std::span<const float>(kNormalCdf)));
  MDS_TRY(ring.flush());

  gpu::CullUniforms& u = uniforms;
  u.grid_origin = glm::vec4(glm::vec3(vol.origin), 0.0f);
  u.grid_cell = glm::vec4(glm::vec3(vol.cell), float(1.0 / (vol.cell.x * vol.cell.y * vol.cell.z)));
  u.grid_dims = glm::uvec4(uint32_t(vol.dims.x), uint32_t(vol.dims.y), uint32_t(vol.dims.z), bins);
  set_pixel_uniforms();
  u.thresholds = glm::vec4(float(settings.c_occ), float(settings.c_medium), 0.0f, 0.0f);  // .z per view
  footprint_radius = s.footprint_radius;
  u.params = glm::uvec4(uint32_t(settings.acceptance), settings.n_budget, budget, 0u);
  scene_flags = node_density ? gpu::kCullNodeDensity : 0u;
  u.counts = glm::uvec4(meshlet_count, node_count, 0u, settings.seed);
  return {};
}

// The buffers and images with one entry per pixel (or pyramid texel): created with the loop and
// again by resize(); bins, levels and the size uniforms follow the size.
Status CullLoop::Impl::create_pixel_buffers() {
  auto& alloc = ctx->allocator();
  const uint64_t px = uint64_t(width) * height;
  auto make = [&](vk::Buffer& b, uint64_t bytes, const char* what, VkBufferUsageFlags extra = 0) -> Status {
    if (bytes > ctx->limits().maxStorageBufferRange)
      return make_error(Errc::budget, "culling: {} need {} bytes, more than maxStorageBufferRange ({})", what, bytes,
                        ctx->limits().maxStorageBufferRange);
    MDS_ASSIGN_OR_RETURN(b, vk::Buffer::create(alloc, std::max<uint64_t>(bytes, 16), kSsbo | extra,
                                               vk::MemoryIntent::device_local, what));
    return {};
  };
  levels = 1;
  pyramid_texels = px;
  for (uint32_t w = width, h = height; w > 1 || h > 1; ++levels) {
    w = (w + 1) / 2;
    h = (h + 1) / 2;
    pyramid_texels += uint64_t(w) * h;
  }
  const uint32_t s = configured_stride();  // the most blocks any view uses
  const uint64_t blocks = uint64_t((width + s - 1) / s) * ((height + s - 1) / s);
  MDS_TRY(make(histogram, blocks * bins * sizeof(float), "density histograms"));
  MDS_TRY(make(hist_range, blocks * 8, "histogram ranges"));
  MDS_TRY(make(pixel_state, px * 32, "cull/accumulation buffers"));
  MDS_TRY(make(pyramid, pyramid_texels * 8, "confidence pyramid"));
  const SampleRoute forced = forced_route();
  compute_available = ctx->int64_atomics() && forced != SampleRoute::raster &&
                      px * 8 <= ctx->limits().maxStorageBufferRange;
  MDS_TRY(make(sample_buf, compute_available ? px * 8 : 16, "occlusion samples (compute route)"));
  sampled_list = compute_available && sampled_list_wanted() && ctx->compute_ballot() &&
                 sizeof(gpu::CoveredPixelsHeader) + px * 4 <= ctx->limits().maxStorageBufferRange;
  MDS_TRY(make(sampled_pixels, sampled_list ? sizeof(gpu::CoveredPixelsHeader) + px * 4 : 16,
               "sampled pixels (compute route)", VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT));
  const bool image_used = !(compute_available && forced == SampleRoute::compute);
  const uint32_t iw = image_used ? width : 1, ih = image_used ? height : 1;
  MDS_ASSIGN_OR_RETURN(sample_image, vk::Image::create_2d(alloc, iw, ih, kSampleFormat,
                                                          VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
                                                              VK_IMAGE_USAGE_STORAGE_BIT |
                                                              VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                                              VK_IMAGE_USAGE_TRANSFER_SRC_BIT,  // test read-back
                                                          VK_IMAGE_ASPECT_COLOR_BIT, "occlusion sample image"));
  MDS_ASSIGN_OR_RETURN(depth, vk::Image::create_2d(alloc, iw, ih, kDepthFormat,
                                                   VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                                                   VK_IMAGE_ASPECT_DEPTH_BIT, "occlusion sample depth"));
  {
    // The sample image stays bound (cull_update.comp declares it) while the compute route runs:
    // in GENERAL layout from the start (the rasterized route transitions it per pass).
    MDS_TRY(ctx->submit_and_wait([&](VkCommandBuffer cmd) {
      vk::image_barrier(cmd, sample_image.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                        VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                        VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    }));
  }
  return {};
}

void CullLoop::Impl::set_pixel_uniforms() {
  uniforms.viewport = glm::vec4(float(width), float(height), 1.0f / float(width), 1.0f / float(height));
  uniforms.grid_dims.w = bins;
  uniforms.pyramid = glm::uvec4(levels, hist_stride(), hist_blocks_x(), hist_blocks_y());
}

void CullLoop::Impl::write_pixel_descriptors() {
  const VkDescriptorType SSBO = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  set1.write_buffer(gpu::kCullHistogram, SSBO, histogram.get());
  set1.write_buffer(gpu::kCullHistRange, SSBO, hist_range.get());
  set1.write_buffer(gpu::kCullPixelState, SSBO, pixel_state.get());
  set1.write_buffer(gpu::kCullPyramid, SSBO, pyramid.get());
  set1.write_storage_image(gpu::kCullSampleImage, sample_image.view());
  set1.write_buffer(gpu::kCullSampleBuffer, SSBO, sample_buf.get());
  set1.write_buffer(gpu::kCullSampledPixels, SSBO, sampled_pixels.get());
}

Status CullLoop::Impl::create_sets() {
  VkDevice dev = ctx->device();
  auto b = [](uint32_t binding, VkDescriptorType type) {
    return VkDescriptorSetLayoutBinding{binding, type, 1, VK_SHADER_STAGE_ALL, nullptr};
  };
  const VkDescriptorType SSBO = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, UBO = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  const std::vector<VkDescriptorSetLayoutBinding> s0 = {
      b(gpu::kBindFrame, UBO),      b(gpu::kBindNodes, SSBO),    b(gpu::kBindMeshlets, SSBO),
      b(gpu::kBindParticles, SSBO), b(gpu::kBindTypes, SSBO),    b(gpu::kBindDrawList, SSBO),
      b(gpu::kBindRadii, SSBO)};
  for (vk::DescriptorSet* s : {&set0_sample, &set0_draw}) {
    MDS_ASSIGN_OR_RETURN(*s, vk::DescriptorSet::create(dev, s0));
    s->write_buffer(gpu::kBindFrame, UBO, frame_ubo.get());
    s->write_buffer(gpu::kBindNodes, SSBO, scene.nodes);
    s->write_buffer(gpu::kBindMeshlets, SSBO, scene.meshlets);
    s->write_buffer(gpu::kBindParticles, SSBO, scene.particles);
    s->write_buffer(gpu::kBindTypes, SSBO, scene.types);
    s->write_buffer(gpu::kBindRadii, SSBO, scene.radii);
  }
  set0_sample.write_buffer(gpu::kBindDrawList, SSBO, occluder_list.get());
  set0_draw.write_buffer(gpu::kBindDrawList, SSBO, scene.draw_list != VK_NULL_HANDLE ? scene.draw_list
                                                                                      : occluder_list.get());
  MDS_ASSIGN_OR_RETURN(set1, vk::DescriptorSet::create(
                                 dev, {b(gpu::kCullUniforms, UBO), b(gpu::kCullHistogram, SSBO),
                                       b(gpu::kCullHistRange, SSBO), b(gpu::kCullPixelState, SSBO),
                                       b(gpu::kCullPyramid, SSBO), b(gpu::kCullVolume, SSBO),
                                       b(gpu::kCullMeshletVoxels, SSBO), b(gpu::kCullVoxelRefs, SSBO),
                                       b(gpu::kCullMeshletClass, SSBO), b(gpu::kCullNodeClass, SSBO),
                                       b(gpu::kCullCounters, SSBO),
                                       b(gpu::kCullSampleImage, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE),
                                       b(gpu::kCullNormalCdf, SSBO), b(gpu::kCullSampleBuffer, SSBO),
                                       b(gpu::kCullSampledPixels, SSBO)}));
  set1.write_buffer(gpu::kCullUniforms, UBO, cull_ubo.get());
  set1.write_buffer(gpu::kCullHistogram, SSBO, histogram.get());
  set1.write_buffer(gpu::kCullHistRange, SSBO, hist_range.get());
  set1.write_buffer(gpu::kCullPixelState, SSBO, pixel_state.get());
  set1.write_buffer(gpu::kCullPyramid, SSBO, pyramid.get());
  set1.write_buffer(gpu::kCullVolume, SSBO, volume.get());
  set1.write_buffer(gpu::kCullMeshletVoxels, SSBO, meshlet_voxel_first.get());
  set1.write_buffer(gpu::kCullVoxelRefs, SSBO, voxel_refs.get());
  set1.write_buffer(gpu::kCullMeshletClass, SSBO, meshlet_class);
  set1.write_buffer(gpu::kCullNodeClass, SSBO, node_class.get());
  set1.write_buffer(gpu::kCullCounters, SSBO, counters.get());
  set1.write_storage_image(gpu::kCullSampleImage, sample_image.view());
  set1.write_buffer(gpu::kCullNormalCdf, SSBO, normal_cdf.get());
  set1.write_buffer(gpu::kCullSampleBuffer, SSBO, sample_buf.get());
  set1.write_buffer(gpu::kCullSampledPixels, SSBO, sampled_pixels.get());
  return {};
}

Status CullLoop::Impl::create_pipelines() {
  VkDevice dev = ctx->device();
  VkDescriptorSetLayout sl[2] = {set0_sample.layout(), set1.layout()};
  VkPushConstantRange pc{VK_SHADER_STAGE_ALL, 0, sizeof(gpu::CullPush)};
  VkPipelineLayoutCreateInfo li{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  li.setLayoutCount = 2;
  li.pSetLayouts = sl;
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &pc;
  VkPipelineLayout pl = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreatePipelineLayout(dev, &li, nullptr, &pl));
  layout = vk::UniquePipelineLayout(dev, pl);
  MDS_ASSIGN_OR_RETURN(reset_pipe, vk::create_compute_pipeline(dev, layout, "cull_reset.comp"));
  MDS_ASSIGN_OR_RETURN(histogram_pipe, vk::create_compute_pipeline(dev, layout, "cull_histogram.comp"));
  MDS_ASSIGN_OR_RETURN(select_pipe, vk::create_compute_pipeline(dev, layout, "cull_select.comp"));
  {
    // cull_update.comp: kSampleBuffer, kSampledList, local size x, y.
    auto update_spec = [](bool buffer, bool list) {
      vk::SpecConstants s;
      s.add(0u, VkBool32(buffer)).add(1u, VkBool32(list)).add(2u, list ? 64u : 8u).add(3u, list ? 1u : 8u);
      return s;
    };
    vk::SpecConstants image_spec = update_spec(false, false), buffer_spec = update_spec(true, false),
                      list_spec = update_spec(true, true);
    MDS_ASSIGN_OR_RETURN(update_pipe, vk::create_compute_pipeline(dev, layout, "cull_update.comp", &image_spec));
    if (ctx->int64_atomics()) {
      MDS_ASSIGN_OR_RETURN(update_buffer_pipe,
                           vk::create_compute_pipeline(dev, layout, "cull_update.comp", &buffer_spec));
    }
    if (ctx->int64_atomics() && ctx->compute_ballot() && sampled_list_wanted()) {
      MDS_ASSIGN_OR_RETURN(update_list_pipe, vk::create_compute_pipeline(dev, layout, "cull_update.comp", &list_spec));
      MDS_ASSIGN_OR_RETURN(sample_compact_pipe,
                           vk::create_compute_pipeline(dev, layout, "cull_sample_compact.comp"));
    }
  }
  if (ctx->int64_atomics()) {
    // Subgroup-shared large glyphs where the device has ballot and shuffle in compute
    // (cull_sample.comp); MDSTREAM_CULL_COOP=0 takes the per-thread glyphs (A/B runs).
    const char* coop_env = std::getenv("MDSTREAM_CULL_COOP");
    const bool coop = ctx->compute_shuffle() && !(coop_env && std::string(coop_env) == "0");
    MDS_ASSIGN_OR_RETURN(sample_comp_pipe,
                         vk::create_compute_pipeline(dev, layout, coop ? "cull_sample_coop.comp" : "cull_sample.comp"));
  }
  MDS_ASSIGN_OR_RETURN(pyramid_pipe, vk::create_compute_pipeline(dev, layout, "cull_pyramid.comp"));
  {
    // Box tests of many texels shared by their subgroup (cull_classify.comp) where the device
    // has ballot, shuffle and arithmetic in compute and subgroups of at least
    // kCooperativeBoxesMinSubgroup; MDSTREAM_CULL_COOP_BOXES=0 / 1 forces one thread per box /
    // the shared tests (A/B runs).
    const char* coop_env = std::getenv("MDSTREAM_CULL_COOP_BOXES");
    const bool coop = ctx->compute_arithmetic() &&
                      (coop_env ? std::string(coop_env) != "0" : ctx->subgroup_size() >= kCooperativeBoxesMinSubgroup);
    shared_box_tests = coop;
    const char* classify = coop ? "cull_classify_coop.comp" : "cull_classify.comp";
    // kCooperativeTexels; MDSTREAM_CULL_COOP_TEXELS=N for A/B runs.
    const char* texels_env = std::getenv("MDSTREAM_CULL_COOP_TEXELS");
    const int32_t coop_texels = texels_env ? std::max(1, std::atoi(texels_env)) : 256;
    vk::SpecConstants spec;
    spec.add(0u, int32_t(node_extent));  // cull_classify.comp: kNodeExtent
    spec.add(1u, coop_texels);
    MDS_ASSIGN_OR_RETURN(classify_pipe, vk::create_compute_pipeline(dev, layout, classify, &spec));
    if (node_extent != kNodeExtentInMemory) {
      vk::SpecConstants coarse;
      coarse.add(0u, int32_t(kNodeExtentInMemory));
      coarse.add(1u, coop_texels);
      MDS_ASSIGN_OR_RETURN(classify_coarse_pipe, vk::create_compute_pipeline(dev, layout, classify, &coarse));
    }
  }
  MDS_ASSIGN_OR_RETURN(draw_list_pipe, vk::create_compute_pipeline(dev, layout, "cull_draw_list.comp"));
  vk::GraphicsPipelineDesc g;
  g.vertex_shader = "cull_sample.vert";
  g.fragment_shader = "cull_sample.frag";
  g.color_formats = {kSampleFormat};
  g.depth_format = kDepthFormat;
  MDS_ASSIGN_OR_RETURN(sample_pipe, vk::create_graphics_pipeline(dev, layout, g));
  return {};
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
  if (!moving || moving_share >= 1.0) return budget;
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
uint32_t CullLoop::budget() const { return impl_->budget; }
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
  MDS_TRY(m.create_pixel_buffers());  // the old ones are released here (the caller waited for the GPU)
  m.set_pixel_uniforms();
  m.write_pixel_descriptors();
  return {};
}


Status CullLoop::prepare_view(const Camera& camera, uint32_t live_meshlets) {
  impl_->sampled_fraction = -1.0;  // the new view probes its sampled fraction again
  Impl& m = *impl_;
  m.explore_interval = kSampleRouteExplore;  // a new view may favour the other sampling route
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
  const int best_route = m.best_route;
  const bool comparing = m.comparing, probing = m.probing, moving_comparison = m.moving_comparison;
  const uint32_t since_compare = m.since_compare, route_passes[2] = {m.route_passes[0], m.route_passes[1]};
  const bool moving = m.moving;
  Status st;
  for (bool mv : {false, true}) {  // at rest and moving: their classify pipelines differ
    m.moving = mv;
    st = begin_view(camera, 0);
    if (st.ok()) st = m.ctx->submit_and_wait([&](VkCommandBuffer cmd) { record_iteration(cmd, nullptr, 0); });
    if (!st.ok()) break;
  }
  m.moving = moving;
  m.best_route = best_route;
  m.comparing = comparing;
  m.probing = probing;
  m.moving_comparison = moving_comparison;
  m.route_trigger = false;
  m.since_compare = since_compare;
  m.route_passes[0] = route_passes[0];
  m.route_passes[1] = route_passes[1];
  m.compare_ms[0].clear();
  m.compare_ms[1].clear();
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
  if (m.probing && m.route_ts.enabled()) {
    // The probe of the other route (cull_loop.h kSampleRouteProbeShare): measured, not applied.
    m.sample_compute = m.best_route != 1;
    m.route_ts.begin(cmd, m.sample_compute ? "compute_probe" : "raster_probe");
    m.record_sampling_pass(cmd, ts, iteration * m.max_passes(), m.probe_share());
    m.route_ts.end(cmd);
  }
  for (uint32_t p = 0; p < passes; ++p) {
    m.sample_compute = m.choose_compute_route(p, passes);
    ++m.route_passes[m.sample_compute ? 1 : 0];
    const bool timed = (m.comparing || (m.moving && m.best_route >= 0)) && m.route_ts.enabled();
    if (timed)
      m.route_ts.begin(cmd, m.comparing ? (m.sample_compute ? "compute" : "raster")
                                        : (m.sample_compute ? "run_compute" : "run_raster"));
    m.record_sampling_pass(cmd, ts, iteration * m.max_passes() + p);
    if (timed) m.route_ts.end(cmd);
  }

  begin("pyramid");  // Eq. 23
  m.record_pyramid(cmd);
  end();

  begin("classify");  // Sect. 5.1, nodes then meshlets; Sect. 4.4 volume updates
  vkCmdFillBuffer(cmd, m.counters.get(), 0, offsetof(gpu::CullCounters, selected), 0);
  vkCmdFillBuffer(cmd, m.counters.get(), offsetof(gpu::CullCounters, node_class_count), 20, 0);  // + node_changed
  compute_barrier(cmd);
  m.bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE,
         m.moving && m.classify_coarse_pipe ? m.classify_coarse_pipe.get() : m.classify_pipe.get(), m.set0_sample);
  m.push(cmd, 0);
  vk::dispatch_rows(cmd, (m.node_count + 63) / 64, gpu::kDispatchRow);
  compute_barrier(cmd);
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

Result<std::vector<uint32_t>> CullLoop::read_meshlet_classes() {
  Impl& m = *impl_;
  MDS_ASSIGN_OR_RETURN(auto raw, vk::read_buffer(*m.ctx, m.meshlet_class, 0, 4ull * m.meshlet_count));
  std::vector<uint32_t> v(m.meshlet_count);
  std::memcpy(v.data(), raw.data(), v.size() * 4);
  return v;
}
// Block index of pixel i of a width-wide image (histogram blocks of stride s, bx per row).
static size_t hist_block_of(size_t i, uint32_t width, uint32_t s, uint32_t bx) {
  return (i / width / s) * bx + (i % width) / s;
}
Result<std::vector<float>> CullLoop::read_histograms() {
  // The buffer is cumulative (cull_histogram.comp) and per block; hand back per-bin counts per pixel.
  const Impl& m = *impl_;
  const size_t bins = m.bins;
  MDS_ASSIGN_OR_RETURN(std::vector<float> cum, impl_->read<float>(impl_->histogram, m.hist_blocks() * bins));
  const size_t px = size_t(m.width) * m.height;
  std::vector<float> counts(px * bins);
  for (size_t p = 0; p < px; ++p) {
    const float* c = &cum[hist_block_of(p, m.width, m.hist_stride(), m.hist_blocks_x()) * bins];
    for (size_t b = 0; b < bins; ++b) counts[p * bins + b] = b == 0 ? c[0] : c[b] - c[b - 1];
  }
  return counts;
}
Result<std::vector<glm::vec2>> CullLoop::read_hist_ranges() {
  const Impl& m = *impl_;
  MDS_ASSIGN_OR_RETURN(std::vector<glm::vec2> blocks, impl_->read<glm::vec2>(impl_->hist_range, m.hist_blocks()));
  const size_t px = size_t(m.width) * m.height;
  std::vector<glm::vec2> ranges(px);
  for (size_t p = 0; p < px; ++p) ranges[p] = blocks[hist_block_of(p, m.width, m.hist_stride(), m.hist_blocks_x())];
  return ranges;
}
Result<std::vector<glm::vec4>> CullLoop::read_pixel_state() {
  return impl_->read<glm::vec4>(impl_->pixel_state, 2 * size_t(impl_->width) * impl_->height);
}
Result<std::vector<glm::vec2>> CullLoop::read_pyramid() {
  return impl_->read<glm::vec2>(impl_->pyramid, impl_->pyramid_texels);
}
Result<std::vector<int32_t>> CullLoop::read_volume() {
  return impl_->read<int32_t>(impl_->volume, impl_->volume.size() / 4);
}

Status CullLoop::write_histograms(const std::vector<float>& counts, const std::vector<glm::vec2>& ranges) {
  Impl& m = *impl_;
  if (m.hist_stride() != 1)
    return make_error(Errc::invalid_argument, "write_histograms: per-pixel histograms need histogram_stride 1, not {}",
                      m.hist_stride());
  // Per-bin counts in, cumulative sums (double, rounded once) into the buffer.
  std::vector<float> cum(counts.size());
  for (size_t p = 0; p + m.bins <= counts.size(); p += m.bins) {
    double sum = 0.0;
    for (size_t b = 0; b < m.bins; ++b) cum[p + b] = float(sum += double(counts[p + b]));
  }
  MDS_ASSIGN_OR_RETURN(vk::StagingRing ring, vk::StagingRing::create(*m.ctx));
  MDS_TRY(ring.upload_span(m.histogram, 0, std::span<const float>(cum)));
  MDS_TRY(ring.upload_span(m.hist_range, 0, std::span<const glm::vec2>(ranges)));
  return ring.flush();
}

Status CullLoop::write_pyramid_level0(const std::vector<glm::vec2>& dc) {
  Impl& m = *impl_;
  MDS_ASSIGN_OR_RETURN(vk::StagingRing ring, vk::StagingRing::create(*m.ctx));
  MDS_TRY(ring.upload_span(m.pyramid, 0, std::span<const glm::vec2>(dc)));
  return ring.flush();
}

Status CullLoop::run_pyramid_only() {
  Impl& m = *impl_;
  return m.ctx->submit_and_wait([&](VkCommandBuffer cmd) { m.record_pyramid(cmd); });
}

Status CullLoop::run_histogram_only() {
  Impl& m = *impl_;
  return m.ctx->submit_and_wait([&](VkCommandBuffer cmd) { m.record_histogram(cmd, 1); });
}

}  // namespace mds::render::culling
