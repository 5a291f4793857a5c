// The culling loop's GPU resources (see cull_loop.h, cull_loop_impl.h): its buffers, sized from
// the scene and the render size, the descriptor sets over them and the compute and sampling
// pipelines (shaders/cull_*.comp, specialization constants per pass).
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <iterator>

#include "culling/normal_cdf_table.h"
#include "render/culling/cull_loop_impl.h"

namespace mds::render::culling {

Status CullLoop::Impl::make_ssbo(vk::Buffer& b, uint64_t bytes, const char* what, VkBufferUsageFlags extra,
                                 bool keep_capacity) {
  if (bytes > ctx->limits().maxStorageBufferRange)
    return make_error(Errc::budget, "culling: {} need {} bytes, more than maxStorageBufferRange ({})", what, bytes,
                      ctx->limits().maxStorageBufferRange);
  if (keep_capacity) {
    MDS_TRY(vk::ensure_buffer(b, ctx->allocator(), std::max<uint64_t>(bytes, 16), kSsbo | extra,
                              vk::MemoryIntent::device_local, what));
    return {};
  }
  MDS_ASSIGN_OR_RETURN(b, vk::Buffer::create(ctx->allocator(), std::max<uint64_t>(bytes, 16), kSsbo | extra,
                                             vk::MemoryIntent::device_local, what));
  return {};
}

Status CullLoop::Impl::create_buffers(const CullScene& s, const DensityVolume& vol) {
  auto& alloc = ctx->allocator();
  MDS_TRY(create_pixel_buffers());
  MDS_TRY(make_ssbo(volume, vol.counts.size() * 4, "density volume"));
  MDS_TRY(make_ssbo(volume_init, vol.counts.size() * 4, "density volume (initial)"));
  MDS_TRY(make_ssbo(meshlet_voxel_first, s.voxel_first.size() * 4, "voxel list index"));
  MDS_TRY(make_ssbo(voxel_refs, s.voxel_refs.size() * 8, "voxel lists"));
  if (meshlet_class == VK_NULL_HANDLE) {
    MDS_TRY(make_ssbo(own_meshlet_class, uint64_t(meshlet_count) * 4, "meshlet classes"));
    meshlet_class = own_meshlet_class.get();
  }
  MDS_TRY(make_ssbo(node_class, uint64_t(node_count) * 4, "node classes"));
  MDS_TRY(make_ssbo(counters, sizeof(gpu::CullCounters), "cull counters"));
  static constexpr float kNormalCdf[] = {MDS_CULL_NORMAL_CDF_TABLE_VALUES};
  static_assert(std::size(kNormalCdf) == MDS_CULL_NORMAL_TABLE_SIZE);
  MDS_TRY(make_ssbo(normal_cdf, sizeof(kNormalCdf), "normal CDF table"));
  MDS_TRY(make_ssbo(occluder_list, sizeof(gpu::DrawListHeader) + 4ull * meshlet_count, "occluder list",
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
  levels = 1;
  pyramid_texels = px;
  for (uint32_t w = width, h = height; w > 1 || h > 1; ++levels) {
    w = (w + 1) / 2;
    h = (h + 1) / 2;
    pyramid_texels += uint64_t(w) * h;
  }
  const uint32_t s = configured_stride();  // the most blocks any view uses
  const uint64_t blocks = uint64_t((width + s - 1) / s) * ((height + s - 1) / s);
  // Kept at their capacity (vk::ensure_buffer): a resize to a size they hold allocates nothing.
  MDS_TRY(make_ssbo(histogram, blocks * bins * sizeof(float), "density histograms", 0, true));
  MDS_TRY(make_ssbo(hist_range, blocks * 8, "histogram ranges", 0, true));
  MDS_TRY(make_ssbo(pixel_state, px * 32, "cull/accumulation buffers", 0, true));
  MDS_TRY(make_ssbo(pyramid, pyramid_texels * 8, "confidence pyramid", 0, true));
  const SampleRoute forced = forced_route();
  compute_available = ctx->int64_atomics() && forced != SampleRoute::raster &&
                      px * 8 <= ctx->limits().maxStorageBufferRange;
  MDS_TRY(make_ssbo(sample_buf, compute_available ? px * 8 : 16, "occlusion samples (compute route)", 0, true));
  sampled_list = compute_available && sampled_list_wanted() && ctx->compute_ballot() &&
                 sizeof(gpu::CoveredPixelsHeader) + px * 4 <= ctx->limits().maxStorageBufferRange;
  MDS_TRY(make_ssbo(sampled_pixels, sampled_list ? sizeof(gpu::CoveredPixelsHeader) + px * 4 : 16,
                    "sampled pixels (compute route)", VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, true));
  const bool image_used = !(compute_available && forced == SampleRoute::compute);
  const uint32_t iw = image_used ? width : 1, ih = image_used ? height : 1;
  MDS_ASSIGN_OR_RETURN(const bool new_image,
                       vk::ensure_image_2d(sample_image, alloc, iw, ih, kSampleFormat,
                                           VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT |
                                               VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                               VK_IMAGE_USAGE_TRANSFER_SRC_BIT,  // test read-back
                                           VK_IMAGE_ASPECT_COLOR_BIT, "occlusion sample image"));
  MDS_TRY(vk::ensure_image_2d(depth, alloc, iw, ih, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                              VK_IMAGE_ASPECT_DEPTH_BIT, "occlusion sample depth"));
  if (new_image) {
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
  const vk::DescriptorSet* sets[] = {&set0_sample, &set1};  // set0_draw: as set0_sample
  vk::PipelineCache& cache = ctx->pipelines();
  MDS_ASSIGN_OR_RETURN(layout, cache.layout(sets, sizeof(gpu::CullPush)));
  MDS_ASSIGN_OR_RETURN(reset_pipe, cache.compute(layout, "cull_reset.comp"));
  MDS_ASSIGN_OR_RETURN(histogram_pipe, cache.compute(layout, "cull_histogram.comp"));
  MDS_ASSIGN_OR_RETURN(select_pipe, cache.compute(layout, "cull_select.comp"));
  {
    // cull_update.comp: kSampleBuffer, kSampledList, local size x, y.
    auto update_spec = [](bool buffer, bool list) {
      vk::SpecConstants s;
      s.add(0u, VkBool32(buffer)).add(1u, VkBool32(list)).add(2u, list ? 64u : 8u).add(3u, list ? 1u : 8u);
      return s;
    };
    vk::SpecConstants image_spec = update_spec(false, false), buffer_spec = update_spec(true, false),
                      list_spec = update_spec(true, true);
    MDS_ASSIGN_OR_RETURN(update_pipe, cache.compute(layout, "cull_update.comp", &image_spec));
    if (ctx->int64_atomics()) {
      MDS_ASSIGN_OR_RETURN(update_buffer_pipe,
                           cache.compute(layout, "cull_update.comp", &buffer_spec));
    }
    if (ctx->int64_atomics() && ctx->compute_ballot() && sampled_list_wanted()) {
      MDS_ASSIGN_OR_RETURN(update_list_pipe, cache.compute(layout, "cull_update.comp", &list_spec));
      MDS_ASSIGN_OR_RETURN(sample_compact_pipe,
                           cache.compute(layout, "cull_sample_compact.comp"));
    }
  }
  if (ctx->int64_atomics()) {
    // Subgroup-shared large glyphs where the device has ballot and shuffle in compute
    // (cull_sample.comp); MDSTREAM_CULL_COOP=0 takes the per-thread glyphs (A/B runs).
    const char* coop_env = std::getenv("MDSTREAM_CULL_COOP");
    const bool coop = ctx->compute_shuffle() && !(coop_env && std::string(coop_env) == "0");
    MDS_ASSIGN_OR_RETURN(sample_comp_pipe,
                         cache.compute(layout, coop ? "cull_sample_coop.comp" : "cull_sample.comp"));
  }
  MDS_ASSIGN_OR_RETURN(pyramid_pipe, cache.compute(layout, "cull_pyramid.comp"));
  {
    // Box tests of many texels shared by their subgroup (cull_classify.comp) where the device
    // has ballot, shuffle and arithmetic in compute and subgroups of at least
    // kCooperativeBoxesMinSubgroup; MDSTREAM_CULL_COOP_BOXES=0 / 1 forces one thread per box /
    // the shared tests (A/B runs).
    const char* coop_env = std::getenv("MDSTREAM_CULL_COOP_BOXES");
    const bool coop = ctx->compute_arithmetic() &&
                      (coop_env ? std::string(coop_env) != "0" : ctx->subgroup_size() >= kCooperativeBoxesMinSubgroup);
    shared_box_tests = coop;
    // One subgroup per node where box tests are shared (push.mode 2); MDSTREAM_CULL_NODE_SUBGROUP=0
    // keeps one thread per node (mode 0; A/B runs, tools/bench_classify.py).
    const char* node_env = std::getenv("MDSTREAM_CULL_NODE_SUBGROUP");
    nodes_per_group = coop && !(node_env && std::string(node_env) == "0")
                          ? std::max<uint32_t>(1, 64 / std::max<uint32_t>(1, ctx->subgroup_size()))
                          : 0;
    const char* classify = coop ? "cull_classify_coop.comp" : "cull_classify.comp";
    // kCooperativeTexels; MDSTREAM_CULL_COOP_TEXELS=N for A/B runs.
    const char* texels_env = std::getenv("MDSTREAM_CULL_COOP_TEXELS");
    const int32_t coop_texels = texels_env ? std::max(1, std::atoi(texels_env)) : 256;
    // kSharedCells where box tests are shared: a shared test's occupied cells one after the
    // other, each cell's texels over the subgroup (cull_classify.comp cells_in_front_shared; the
    // H200's node pass 0.49-0.64x on the jumps, docs/rendering.md "Shared cells");
    // MDSTREAM_CULL_SHARED_CELLS=0 for A/B runs.
    const char* cells_env = std::getenv("MDSTREAM_CULL_SHARED_CELLS");
    shared_cells = coop && !(cells_env && std::string(cells_env) == "0");
    vk::SpecConstants spec;
    spec.add(0u, int32_t(node_extent));  // cull_classify.comp: kNodeExtent
    spec.add(1u, coop_texels);
    spec.add(2u, VkBool32(shared_cells));
    MDS_ASSIGN_OR_RETURN(classify_pipe, cache.compute(layout, classify, &spec));
    if (node_extent != kNodeExtentInMemory) {
      vk::SpecConstants coarse;
      coarse.add(0u, int32_t(kNodeExtentInMemory));
      coarse.add(1u, coop_texels);
      coarse.add(2u, VkBool32(shared_cells));
      MDS_ASSIGN_OR_RETURN(classify_coarse_pipe, cache.compute(layout, classify, &coarse));
    }
  }
  MDS_ASSIGN_OR_RETURN(draw_list_pipe, cache.compute(layout, "cull_draw_list.comp"));
  vk::GraphicsPipelineDesc g;
  g.vertex_shader = "cull_sample.vert";
  g.fragment_shader = "cull_sample.frag";
  g.color_formats = {kSampleFormat};
  g.depth_format = kDepthFormat;
  MDS_ASSIGN_OR_RETURN(sample_pipe, cache.graphics(layout, g));
  return {};
}

}  // namespace mds::render::culling
