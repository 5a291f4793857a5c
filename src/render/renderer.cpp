#include "render/renderer.h"

#include <chrono>
#include <cstring>

#include "gpu_types.h"
#include "vk/commands.h"
#include "vk/pipeline.h"
#include "vk/staging.h"
#include "vk/timestamps.h"

namespace mds::render {

namespace {
constexpr VkFormat kColorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
}  // namespace

struct Renderer::Impl {
  vk::Context* ctx = nullptr;
  RenderSettings settings;
  glm::dvec3 origin{0.0};
  Bounds bounds;
  uint32_t meshlet_count = 0;
  uint64_t particle_count = 0;
  uint32_t max_meshlet = 0;
  uint32_t flags = 0;
  float radius_min = 0, radius_max = 0;
  uint64_t upload_bytes = 0;

  vk::Buffer nodes, meshlets, particles, types, radii, draw_list, indices, frame_ubo;
  vk::Image color, depth, accum;
  vk::DescriptorSet set;
  vk::UniquePipelineLayout layout;
  vk::UniquePipeline draw_list_pipe, sphere_pipe, accum_pipe;
  vk::FrameSlot slot;
  vk::TimestampPool timestamps;
  vk::DeferredDestroyer destroyer;
  uint64_t frame_index = 0;
  bool rendered = false;

  Status upload(const SceneData& scene);
  Status create_targets();
  Status create_pipelines();
  void record_pass(VkCommandBuffer cmd, bool first);
};

Status Renderer::Impl::upload(const SceneData& scene) {
  auto& alloc = ctx->allocator();
  const VkBufferUsageFlags ssbo = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  const uint64_t max_range = ctx->limits().maxStorageBufferRange;
  auto check_range = [&](uint64_t bytes, const char* what) -> Status {
    if (bytes > max_range)
      return make_error(Errc::budget,
                        "{} need {} bytes, more than this device's maxStorageBufferRange ({} bytes); the "
                        "in-memory renderer binds each array whole (streaming lifts this)",
                        what, bytes, max_range);
    return {};
  };
  MDS_TRY(check_range(scene.particles.size() * 2, "particles"));
  MDS_TRY(check_range(scene.meshlets.size() * sizeof(gpu::GpuMeshlet), "meshlet records"));
  MDS_TRY(check_range(scene.nodes.size() * sizeof(gpu::GpuNode), "node records"));
  MDS_TRY(check_range(sizeof(gpu::DrawListHeader) + 4ull * scene.meshlets.size(), "draw list"));

  MDS_ASSIGN_OR_RETURN(nodes, vk::Buffer::create(alloc, scene.nodes.size() * sizeof(gpu::GpuNode), ssbo,
                                                 vk::MemoryIntent::device_local, "node records"));
  MDS_ASSIGN_OR_RETURN(meshlets, vk::Buffer::create(alloc, scene.meshlets.size() * sizeof(gpu::GpuMeshlet), ssbo,
                                                    vk::MemoryIntent::device_local, "meshlet records"));
  MDS_ASSIGN_OR_RETURN(particles, vk::Buffer::create(alloc, scene.particles.size() * sizeof(uint16_t), ssbo,
                                                     vk::MemoryIntent::device_local, "particles"));
  MDS_ASSIGN_OR_RETURN(types, vk::Buffer::create(alloc, scene.types.size() * sizeof(gpu::GpuType), ssbo,
                                                 vk::MemoryIntent::device_local, "type table"));
  std::vector<uint16_t> radii_padded = scene.radius_q;
  if (radii_padded.size() % 2) radii_padded.push_back(0);
  if (radii_padded.empty()) radii_padded.assign(2, 0);
  MDS_ASSIGN_OR_RETURN(radii, vk::Buffer::create(alloc, radii_padded.size() * sizeof(uint16_t), ssbo,
                                                 vk::MemoryIntent::device_local, "particle radii"));
  MDS_ASSIGN_OR_RETURN(draw_list,
                       vk::Buffer::create(alloc, sizeof(gpu::DrawListHeader) + 4ull * scene.meshlets.size(),
                                          ssbo | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                          vk::MemoryIntent::device_local, "draw list"));
  std::vector<uint16_t> idx(6 * size_t(max_meshlet));
  for (uint32_t i = 0; i < max_meshlet; ++i) {
    const uint16_t b = uint16_t(4 * i);
    const uint16_t q[6] = {b, uint16_t(b + 1), uint16_t(b + 2), uint16_t(b + 2), uint16_t(b + 1), uint16_t(b + 3)};
    std::memcpy(&idx[6 * i], q, sizeof(q));
  }
  MDS_ASSIGN_OR_RETURN(indices, vk::Buffer::create(alloc, idx.size() * sizeof(uint16_t),
                                                   VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                   vk::MemoryIntent::device_local, "billboard indices"));
  MDS_ASSIGN_OR_RETURN(frame_ubo, vk::Buffer::create(alloc, sizeof(gpu::FrameUniforms),
                                                     VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, vk::MemoryIntent::upload,
                                                     "frame uniforms"));

  MDS_ASSIGN_OR_RETURN(vk::StagingRing ring, vk::StagingRing::create(*ctx));
  MDS_TRY(ring.upload_span(nodes, 0, std::span<const gpu::GpuNode>(scene.nodes)));
  MDS_TRY(ring.upload_span(meshlets, 0, std::span<const gpu::GpuMeshlet>(scene.meshlets)));
  MDS_TRY(ring.upload_span(particles, 0, std::span<const uint16_t>(scene.particles)));
  MDS_TRY(ring.upload_span(types, 0, std::span<const gpu::GpuType>(scene.types)));
  MDS_TRY(ring.upload_span(radii, 0, std::span<const uint16_t>(radii_padded)));
  MDS_TRY(ring.upload_span(indices, 0, std::span<const uint16_t>(idx)));
  MDS_TRY(ring.flush());
  upload_bytes = ring.bytes_uploaded();
  return {};
}

Status Renderer::Impl::create_targets() {
  auto& alloc = ctx->allocator();
  const uint32_t w = settings.width, h = settings.height;
  MDS_ASSIGN_OR_RETURN(color, vk::Image::create_2d(alloc, w, h, kColorFormat,
                                                   VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT,
                                                   VK_IMAGE_ASPECT_COLOR_BIT, "colour target"));
  MDS_ASSIGN_OR_RETURN(depth, vk::Image::create_2d(alloc, w, h, kDepthFormat,
                                                   VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT |
                                                       VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                                   VK_IMAGE_ASPECT_DEPTH_BIT, "depth target"));
  MDS_ASSIGN_OR_RETURN(accum, vk::Image::create_2d(alloc, w, h, kColorFormat,
                                                   VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                                       VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                                   VK_IMAGE_ASPECT_COLOR_BIT, "accumulation image"));
  return {};
}

Status Renderer::Impl::create_pipelines() {
  VkDevice dev = ctx->device();
  auto b = [](uint32_t binding, VkDescriptorType type) {
    return VkDescriptorSetLayoutBinding{binding, type, 1, VK_SHADER_STAGE_ALL, nullptr};
  };
  const VkDescriptorType SSBO = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  MDS_ASSIGN_OR_RETURN(set, vk::DescriptorSet::create(
                                dev, {b(gpu::kBindFrame, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER), b(gpu::kBindNodes, SSBO),
                                      b(gpu::kBindMeshlets, SSBO), b(gpu::kBindParticles, SSBO),
                                      b(gpu::kBindTypes, SSBO), b(gpu::kBindDrawList, SSBO), b(gpu::kBindRadii, SSBO),
                                      b(gpu::kBindColorImage, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE),
                                      b(gpu::kBindAccumImage, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE)}));
  set.write_buffer(gpu::kBindFrame, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, frame_ubo.get());
  set.write_buffer(gpu::kBindNodes, SSBO, nodes.get());
  set.write_buffer(gpu::kBindMeshlets, SSBO, meshlets.get());
  set.write_buffer(gpu::kBindParticles, SSBO, particles.get());
  set.write_buffer(gpu::kBindTypes, SSBO, types.get());
  set.write_buffer(gpu::kBindDrawList, SSBO, draw_list.get());
  set.write_buffer(gpu::kBindRadii, SSBO, radii.get());
  set.write_storage_image(gpu::kBindColorImage, color.view());
  set.write_storage_image(gpu::kBindAccumImage, accum.view());
  MDS_ASSIGN_OR_RETURN(layout, vk::create_pipeline_layout(dev, set.layout()));
  MDS_ASSIGN_OR_RETURN(draw_list_pipe, vk::create_compute_pipeline(dev, layout, "draw_list_all.comp"));
  MDS_ASSIGN_OR_RETURN(accum_pipe, vk::create_compute_pipeline(dev, layout, "accumulate.comp"));
  vk::GraphicsPipelineDesc g;
  g.vertex_shader = "sphere.vert";
  g.fragment_shader = "sphere.frag";
  g.color_formats = {kColorFormat};
  g.depth_format = kDepthFormat;
  MDS_ASSIGN_OR_RETURN(sphere_pipe, vk::create_graphics_pipeline(dev, layout, g));
  return {};
}

void Renderer::Impl::record_pass(VkCommandBuffer cmd, bool first) {
  const uint32_t w = settings.width, h = settings.height;
  VkDescriptorSet ds = set.set();
  timestamps.reset(cmd);
  if (first) {
    vk::image_barrier(cmd, accum.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL,
                      VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    VkClearColorValue zero{};
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, accum.get(), VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
    vk::image_barrier(cmd, accum.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL,
                      VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  }

  // 1. Draw list (no cull: every meshlet).
  timestamps.begin(cmd, "draw_list");
  gpu::DrawListHeader head{};
  head.index_count = 6 * max_meshlet;
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
                     VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  vkCmdUpdateBuffer(cmd, draw_list.get(), 0, sizeof(head), &head);
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, draw_list_pipe);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &ds, 0, nullptr);
  vkCmdDispatch(cmd, (meshlet_count + 63) / 64, 1, 1);
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  timestamps.end(cmd);

  // 2. Draw the listed meshlets into colour + depth.
  timestamps.begin(cmd, "draw");
  vk::image_barrier(cmd, color.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                    VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                    VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
  vk::image_barrier(cmd, depth.get(), VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                    VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                    VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
  const glm::vec3 bg(srgb_to_linear(settings.background_srgb.r), srgb_to_linear(settings.background_srgb.g),
                     srgb_to_linear(settings.background_srgb.b));
  VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  ca.imageView = color.view();
  ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  ca.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  ca.clearValue.color = {{bg.r, bg.g, bg.b, 0.0f}};
  VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  da.imageView = depth.view();
  da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  da.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  da.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  da.clearValue.depthStencil = {1.0f, 0};
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {w, h}};
  ri.layerCount = 1;
  ri.colorAttachmentCount = 1;
  ri.pColorAttachments = &ca;
  ri.pDepthAttachment = &da;
  vkCmdBeginRendering(cmd, &ri);
  VkViewport vp{0.0f, 0.0f, float(w), float(h), 0.0f, 1.0f};
  VkRect2D sc{{0, 0}, {w, h}};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  vkCmdSetScissor(cmd, 0, 1, &sc);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, sphere_pipe);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &ds, 0, nullptr);
  vkCmdBindIndexBuffer(cmd, indices.get(), 0, VK_INDEX_TYPE_UINT16);
  vkCmdDrawIndexedIndirect(cmd, draw_list.get(), 0, 1, sizeof(VkDrawIndexedIndirectCommand));
  vkCmdEndRendering(cmd);
  timestamps.end(cmd);

  // 3. Accumulate.
  timestamps.begin(cmd, "accumulate");
  vk::image_barrier(cmd, color.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                    VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                    VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                    VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, accum_pipe);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &ds, 0, nullptr);
  vkCmdDispatch(cmd, (w + 7) / 8, (h + 7) / 8, 1);
  timestamps.end(cmd);
}

Result<std::unique_ptr<Renderer>> Renderer::create(vk::Context& ctx, const SceneData& scene,
                                                   const RenderSettings& settings) {
  if (settings.width == 0 || settings.height == 0 || settings.width > 16384 || settings.height > 16384)
    return make_error(Errc::invalid_argument, "image size {}x{} outside 1..16384", settings.width, settings.height);
  if (settings.spp == 0) return make_error(Errc::invalid_argument, "--spp must be >= 1");
  if (scene.meshlets.empty()) return make_error(Errc::invalid_argument, "the scene has no particles");
  std::unique_ptr<Renderer> r(new Renderer());
  r->impl_ = std::make_unique<Impl>();
  Impl& m = *r->impl_;
  m.ctx = &ctx;
  m.settings = settings;
  m.origin = scene.origin;
  m.bounds = scene.bounds;
  m.meshlet_count = uint32_t(scene.meshlets.size());
  m.particle_count = scene.particle_count();
  m.max_meshlet = scene.max_meshlet_particles;
  m.flags = scene.per_particle_radius ? gpu::kFramePerParticleRadius : 0u;
  m.radius_min = scene.radius_min;
  m.radius_max = scene.radius_max;
  MDS_TRY(m.upload(scene));
  MDS_TRY(m.create_targets());
  MDS_TRY(m.create_pipelines());
  MDS_ASSIGN_OR_RETURN(m.slot, vk::FrameSlot::create(ctx));
  MDS_ASSIGN_OR_RETURN(m.timestamps, vk::TimestampPool::create(ctx));
  return r;
}

Renderer::~Renderer() {
  if (impl_) {
    (void)impl_->slot.wait();
    impl_->destroyer.collect(UINT64_MAX);
  }
}

Result<FrameImage> Renderer::render(const Camera& camera_in, RenderStats* stats) {
  Impl& m = *impl_;
  const auto t0 = std::chrono::steady_clock::now();
  Camera camera = camera_in;
  fit_clip_planes(camera, m.bounds);
  const uint32_t w = m.settings.width, h = m.settings.height;
  const double aspect = double(w) / double(h);
  const glm::dmat4 view = view_matrix(camera, m.origin);
  vk::TimestampPool fresh;
  MDS_ASSIGN_OR_RETURN(fresh, vk::TimestampPool::create(*m.ctx));
  m.timestamps = std::move(fresh);

  for (uint32_t s = 0; s < m.settings.spp; ++s) {
    const glm::dvec2 jitter_px = halton_jitter(s);
    const glm::dmat4 proj = projection_matrix(camera, aspect, {2.0 * jitter_px.x / w, 2.0 * jitter_px.y / h});
    MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, m.slot.begin());
    MDS_TRY(m.timestamps.collect());  // previous pass has completed (begin() waited)
    m.destroyer.collect(m.frame_index);
    gpu::FrameUniforms fu{};
    fu.view = glm::mat4(view);
    fu.proj = glm::mat4(proj);
    fu.inv_proj = glm::mat4(glm::inverse(proj));
    fu.viewport = glm::vec4(float(w), float(h), 1.0f / float(w), 1.0f / float(h));
    fu.radius_range = glm::vec4(m.radius_min, m.radius_max - m.radius_min, float(camera.near), float(camera.far));
    fu.counts = glm::uvec4(m.meshlet_count, m.max_meshlet, m.flags | (camera.ortho ? gpu::kFrameOrtho : 0u), s);
    std::memcpy(m.frame_ubo.mapped(), &fu, sizeof(fu));
    m.frame_ubo.flush();
    m.record_pass(cmd, s == 0);
    MDS_TRY(m.slot.submit(m.ctx->queue()));
    ++m.frame_index;
  }
  MDS_TRY(m.slot.wait());
  MDS_TRY(m.timestamps.collect());
  m.rendered = true;

  MDS_ASSIGN_OR_RETURN(std::vector<std::byte> raw, vk::read_image(*m.ctx, m.accum, VK_IMAGE_LAYOUT_GENERAL, 16));
  FrameImage img;
  img.width = w;
  img.height = h;
  img.rgba.resize(size_t(w) * h * 4);
  std::memcpy(img.rgba.data(), raw.data(), img.rgba.size() * sizeof(float));
  const float inv = 1.0f / float(m.settings.spp);
  for (float& v : img.rgba) v *= inv;

  if (stats) {
    stats->device = m.ctx->info().name;
    stats->particles = m.particle_count;
    stats->meshlets = m.meshlet_count;
    stats->spp = m.settings.spp;
    stats->width = w;
    stats->height = h;
    stats->pass_ms_median.clear();
    stats->frame_ms_median = 0.0;
    for (const auto& [name, v] : m.timestamps.samples()) {
      double med = vk::median(v);
      stats->pass_ms_median[name] = med;
      stats->frame_ms_median += med;
    }
    stats->wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    stats->upload_bytes = m.upload_bytes;
    stats->device_bytes = m.ctx->allocator().peak(vk::MemoryIntent::device_local);
    stats->near = camera.near;
    stats->far = camera.far;
  }
  return img;
}

Result<std::vector<float>> Renderer::read_last_depth() {
  Impl& m = *impl_;
  if (!m.rendered) return make_error(Errc::internal, "read_last_depth() before render()");
  MDS_ASSIGN_OR_RETURN(std::vector<std::byte> raw,
                       vk::read_image(*m.ctx, m.depth, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, 4));
  std::vector<float> d(size_t(m.settings.width) * m.settings.height);
  std::memcpy(d.data(), raw.data(), d.size() * sizeof(float));
  return d;
}

}  // namespace mds::render
