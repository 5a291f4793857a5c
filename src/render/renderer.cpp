// The renderer's resources (scene upload, frame resources, draw buffers, targets, pipelines),
// Renderer::create, the one-shot render() to a converged image and the read-backs. Command
// recording is in renderer_record.cpp, the progressive API and streaming in
// renderer_progressive.cpp; see renderer.h and renderer_impl.h.
#include "render/renderer.h"

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <optional>

#include "gpu_types.h"
#include "render/cell_lines.h"
#include "render/renderer_impl.h"
#include "vk/commands.h"
#include "vk/pipeline.h"
#include "vk/staging.h"

namespace mds::render {

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
  std::vector<uint16_t> property_padded = scene.property_q;  // two uint16 per uint, as the radii
  if (property_padded.size() % 2) property_padded.push_back(0);
  if (property_padded.empty()) property_padded.assign(2, 0);
  MDS_ASSIGN_OR_RETURN(property, vk::Buffer::create(alloc, property_padded.size() * sizeof(uint16_t), ssbo,
                                                    vk::MemoryIntent::device_local, "particle property"));
  // RGBA8 per particle; 16 bytes where the store has no colours (a binding needs a buffer).
  MDS_ASSIGN_OR_RETURN(particle_color, vk::Buffer::create(alloc, std::max<size_t>(scene.color.size() * 4, 16), ssbo,
                                                          vk::MemoryIntent::device_local, "particle colours"));
  MDS_TRY(create_draw_buffers(scene.meshlets.size()));
  meshlets_h = meshlets.get();
  particles_h = particles.get();
  radii_h = radii.get();
  property_h = property.get();
  color_h = particle_color.get();

  MDS_ASSIGN_OR_RETURN(vk::StagingRing ring, vk::StagingRing::create(*ctx));
  MDS_TRY(ring.upload_span(nodes, 0, std::span<const gpu::GpuNode>(scene.nodes)));
  MDS_TRY(ring.upload_span(meshlets, 0, std::span<const gpu::GpuMeshlet>(scene.meshlets)));
  MDS_TRY(ring.upload_span(particles, 0, std::span<const uint16_t>(scene.particles)));
  std::vector<gpu::GpuType> type_table = scene.types;
  set_type_colors(type_table, settings.type_colors_srgb);
  MDS_TRY(ring.upload_span(types, 0, std::span<const gpu::GpuType>(type_table)));
  MDS_TRY(ring.upload_span(radii, 0, std::span<const uint16_t>(radii_padded)));
  MDS_TRY(ring.upload_span(property, 0, std::span<const uint16_t>(property_padded)));
  if (!scene.color.empty()) MDS_TRY(ring.upload_span(particle_color, 0, std::span<const uint32_t>(scene.color)));
  MDS_TRY(ring.flush());
  upload_bytes = ring.bytes_uploaded();
  return {};
}

Status Renderer::Impl::create_frame_resources() {
  MDS_TRY(create_targets());
  MDS_TRY(create_pipelines());
  MDS_ASSIGN_OR_RETURN(slot, vk::FrameSlot::create(*ctx));
  MDS_ASSIGN_OR_RETURN(timestamps, vk::TimestampPool::create(*ctx, timestamp_capacity()));
  return {};
}

// The draw list (a meshlet id per slot), the sprite pre-pass output (GpuSprite records for one
// chunk of the list: the whole list where they fit the device's range, else the list is drawn
// in chunks; none on the mesh path) and the frame uniforms.
Status Renderer::Impl::create_draw_buffers(uint64_t meshlet_slots) {
  auto& alloc = ctx->allocator();
  const VkBufferUsageFlags ssbo = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  const uint64_t max_range = ctx->limits().maxStorageBufferRange;
  const uint64_t max_meshlet_slots = std::max<uint64_t>(max_meshlet, 1);
  // A particle's visibility id is its draw-list entry x max_meshlet + local (GpuSprite.vis_id).
  if ((uint64_t(meshlet_slots) + 1) * max_meshlet_slots >= gpu::kVisCell)  // kVisCell, kVisEmpty: reserved
    return make_error(Errc::budget, "{} meshlet slots of up to {} particles exceed the 32-bit particle ids of a frame",
                      meshlet_slots, max_meshlet_slots);
  // Sprite records: 48 B each, bound whole; the id lists (quads, small sprites) take 8 B each.
  // A chunk is a run of list entries, so one chunk takes a record per particle a full list could
  // hold, meshlet slots x max meshlet size (1.0-1.25x the particle slots), where the device allows.
  uint64_t sprite_capacity = std::min<uint64_t>(std::max<uint64_t>(meshlet_slots, 1) * max_meshlet_slots,
                                                std::min(max_range / sizeof(gpu::GpuSprite), max_range / 8));
  // The compute rasterization runs one invocation per small sprite in one row of workgroups
  // (the pre-pass counts raster_x up per 64): at most maxComputeWorkGroupCount[0] x 64 sprites
  // a chunk (4.2 M, 201 MB of records, where a device reports the minimum 65535; a larger list
  // is drawn in chunks). The records' bytes are bounded by the range above, which the context
  // lowers to the largest single allocation (vk/context.h).
  sprite_capacity = std::min<uint64_t>(sprite_capacity, uint64_t(ctx->limits().maxComputeWorkGroupCount[0]) * 64);
  if (settings.sprite_capacity > 0) sprite_capacity = std::min(sprite_capacity, settings.sprite_capacity);
  sprite_capacity = std::max(sprite_capacity, max_meshlet_slots);  // a chunk holds one meshlet at least
  if (mesh_path) {  // no records: the task/mesh path makes its sprites in place, in one launch
    // The task payload names a draw-list entry x kMeshChunksMax + chunk in 32 bits.
    if (uint64_t(meshlet_slots) * gpu::kMeshChunksMax > 0xffffffffull)
      return make_error(Errc::budget, "{} meshlet slots exceed the task payload's 32-bit entries", meshlet_slots);
    sprite_capacity = 1;
    chunk_meshlets = 0xffffffffu;
    sprite_chunks = 1;
  } else {
    chunk_meshlets = uint32_t(std::min<uint64_t>(sprite_capacity / max_meshlet_slots, 0xffffffffu));
    sprite_chunks = uint32_t(std::max<uint64_t>(1, (meshlet_slots + chunk_meshlets - 1) / chunk_meshlets));
  }
  MDS_ASSIGN_OR_RETURN(draw_list,
                       vk::Buffer::create(alloc, sizeof(gpu::DrawListHeader) + 4ull * meshlet_slots,
                                          ssbo | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                          vk::MemoryIntent::device_local, "draw list"));
  MDS_ASSIGN_OR_RETURN(sprites, vk::Buffer::create(alloc, sprite_capacity * sizeof(gpu::GpuSprite), ssbo,
                                                   vk::MemoryIntent::device_local, "sprite records"));
  // Header, then two id lists of `capacity` uints (quads; small sprites for the compute
  // rasterization): 8 bytes per sprite, next to 48 for its record.
  MDS_ASSIGN_OR_RETURN(sprite_draw,
                       vk::Buffer::create(alloc, sizeof(gpu::SpriteDrawHeader) + 8 * sprite_capacity,
                                          ssbo | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                          vk::MemoryIntent::device_local,
                                          "sprite draw commands"));
  MDS_ASSIGN_OR_RETURN(frame_ubo, vk::Buffer::create(alloc, sizeof(gpu::FrameUniforms),
                                                     VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, vk::MemoryIntent::upload,
                                                     "frame uniforms"));
  gpu::SpriteDrawHeader sprite_head{};
  sprite_head.capacity = uint32_t(sprite_capacity);
  sprite_head.chunk_meshlets = chunk_meshlets;
  MDS_ASSIGN_OR_RETURN(vk::StagingRing ring, vk::StagingRing::create(*ctx, 1 << 16));
  MDS_TRY(ring.upload_span(sprite_draw, 0, std::span<const gpu::SpriteDrawHeader>(&sprite_head, 1)));
  MDS_TRY(ring.flush());
  scratch_bytes = sprites.size() + sprite_draw.size() + draw_list.size();
  return {};
}

Status Renderer::Impl::create_cull(const culling::CullScene& cs, const culling::DensityVolume& vol) {
  culling::SceneBuffers sb{nodes.get(), meshlets_h, particles_h, types.get(), radii_h, draw_list.get(),
                           meshlet_class_h};
  MDS_ASSIGN_OR_RETURN(cull, culling::CullLoop::create(*ctx, cs, vol, sb, settings.width, settings.height,
                                                       settings.cull_settings));
  write_occlusion_descriptor();
  // Warm-up with no occluder candidates (nothing is drawn; a streaming cache hears nothing of
  // it): on lavapipe the first view's frame paid ~18 ms in begin_view and ~30 ms in its culling
  // passes for the first use of the pipelines and buffers (docs/streaming.md "Warm-up").
  MDS_ASSIGN_OR_RETURN(Camera warm, default_view(0, bounds, 40.0, double(settings.width) / settings.height));
  fit_clip_planes(warm, bounds);
  return cull->warm_up(warm);
}

void Renderer::Impl::write_occlusion_descriptor() {
  // Without culling the test is off (frame.occlusion.z = 0) and reads nothing: any buffer will do.
  set.write_buffer(gpu::kBindOcclusionPyramid, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                   cull ? cull->pyramid_buffer() : nodes.get());
}

// The route is decided once, at creation (renderer_impl.h); resize() keeps it.
Status Renderer::Impl::create_targets() {
  auto& alloc = ctx->allocator();
  const uint32_t w = settings.width, h = settings.height;
  const uint64_t vis_bytes = 8ull * w * h;  // one uint64 per pixel: depth bits << 32 | sprite index
  const bool vis_fits = vis_bytes <= ctx->limits().maxStorageBufferRange;
  if (!targets_created) {
    // MDSTREAM_PIXEL_ROUTE=attachments forces the attachment route (A/B measurements).
    if (const char* e = std::getenv("MDSTREAM_PIXEL_ROUTE"); e && std::string(e) == "attachments")
      settings.visibility_route = false;
    // MDSTREAM_ACCUM=image forces the image accumulation (A/B measurements).
    if (const char* e = std::getenv("MDSTREAM_ACCUM")) settings.accumulation_buffer = std::string(e) != "image";
    vis_route = settings.visibility_route && ctx->int64_atomics() && vis_fits;
    targets_created = true;
  } else if (vis_route && !vis_fits) {
    return make_error(Errc::budget, "{}x{}: the visibility buffer ({} bytes) exceeds maxStorageBufferRange ({})", w,
                      h, vis_bytes, ctx->limits().maxStorageBufferRange);
  }
  // The size-dependent targets keep their capacity (vk::ensure_buffer / ensure_image_2d): a
  // resize to a size they hold, as dynamic resolution's every few frames, allocates nothing.
  if (vis_route) {
    color = {};
    depth = {};
    MDS_TRY(vk::ensure_buffer(visibility, alloc, vis_bytes,
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                  VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                              vk::MemoryIntent::device_local, "visibility buffer"));
  } else {
    MDS_TRY(vk::ensure_image_2d(color, alloc, w, h, kColorFormat,
                                VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT,
                                VK_IMAGE_ASPECT_COLOR_BIT, "colour target"));
    MDS_TRY(vk::ensure_image_2d(depth, alloc, w, h, kDepthFormat,
                                VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                VK_IMAGE_ASPECT_DEPTH_BIT, "depth target"));
    MDS_TRY(vk::ensure_buffer(visibility, alloc, 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, vk::MemoryIntent::device_local,
                              "visibility buffer (unused)"));
  }
  covered_list = vis_route && settings.covered_pixel_list && ctx->compute_ballot();
  const uint64_t covered_bytes = covered_list ? sizeof(gpu::CoveredPixelsHeader) + 4ull * w * h : 16;
  MDS_TRY(vk::ensure_buffer(covered, alloc, covered_bytes,
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT,
                            vk::MemoryIntent::device_local, covered_list ? "covered pixels" : "covered pixels (unused)"));
  MDS_TRY(vk::ensure_buffer(coverage_rb, alloc, 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, vk::MemoryIntent::readback,
                            "covered pixel count"));
  view_coverage = -1;  // new targets: probe again
  coverage_probe_pending = false;
  // The accumulation: 16 B/pixel (1920x1080: 33 MB) in a buffer where that fits the range.
  const uint64_t accum_bytes = 16ull * w * h;
  accum_in_buffer = settings.accumulation_buffer && accum_bytes <= ctx->limits().maxStorageBufferRange;
  MDS_TRY(vk::ensure_buffer(accum_buf, alloc, accum_in_buffer ? accum_bytes : 16,
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                            vk::MemoryIntent::device_local,
                            accum_in_buffer ? "accumulation buffer" : "accumulation buffer (unused)"));
  MDS_TRY(vk::ensure_image_2d(accum, alloc, accum_in_buffer ? 1 : w, accum_in_buffer ? 1 : h, kColorFormat,
                              VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                  VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                              VK_IMAGE_ASPECT_COLOR_BIT,
                              accum_in_buffer ? "accumulation image (unused)" : "accumulation image"));
  return {};
}

void Renderer::Impl::write_accumulation_descriptors() {
  set.write_storage_image(gpu::kBindAccumImage, accum.view());
  set.write_buffer(gpu::kBindAccumBuffer, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, accum_buf.get());
  set.write_buffer(gpu::kBindCoveredPixels, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, covered.get());
}

Status Renderer::Impl::create_accumulate_pipeline() {
  // list: visibility_resolve.comp's kCoveredList and its local size.
  auto make = [&](const char* shader, bool list) -> Result<VkPipeline> {
    vk::SpecConstants spec;
    spec.add(0u, VkBool32(accum_in_buffer));  // accumulation.h: kAccumBuffer
    if (vis_route)
      spec.add(1u, VkBool32(list)).add(2u, list ? 64u : 16u).add(3u, list ? 1u : 16u).add(4u, VkBool32(chunked_ids()));
    return ctx->pipelines().compute(layout, shader, &spec);
  };
  if (vis_route) {
    MDS_ASSIGN_OR_RETURN(full_resolve_pipe, make("visibility_resolve.comp", false));
    if (covered_list) {
      MDS_ASSIGN_OR_RETURN(resolve_pipe, make("visibility_resolve.comp", true));
    }
  } else {
    MDS_ASSIGN_OR_RETURN(accum_pipe, make("accumulate.comp", false));
  }
  accum_pipe_in_buffer = accum_in_buffer;
  return {};
}

Result<std::vector<float>> Renderer::Impl::read_average(uint32_t sample_count) {
  const size_t n = size_t(settings.width) * settings.height * 4;
  std::vector<float> px(n);
  std::vector<std::byte> raw;
  if (accum_in_buffer) {
    MDS_ASSIGN_OR_RETURN(raw, vk::read_buffer(*ctx, accum_buf, 0, n * sizeof(float)));
  } else {
    MDS_ASSIGN_OR_RETURN(raw,
                         vk::read_image(*ctx, accum, VK_IMAGE_LAYOUT_GENERAL, 16, settings.width, settings.height));
  }
  std::memcpy(px.data(), raw.data(), n * sizeof(float));
  const glm::vec3 bg = background_linear();
  const float spp = float(sample_count), inv = 1.0f / spp;
  for (size_t i = 0; i < n; i += 4) {
    const float uncovered = spp - px[i + 3];  // samples that saw the background
    for (int c = 0; c < 3; ++c) px[i + c] = (px[i + c] + bg[c] * uncovered) * inv;
    px[i + 3] *= inv;
  }
  return px;
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
                                      b(gpu::kBindAccumImage, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE),
                                      b(gpu::kBindSprites, SSBO), b(gpu::kBindSpriteDraw, SSBO),
                                      b(gpu::kBindVisibility, SSBO), b(gpu::kBindAccumBuffer, SSBO),
                                      b(gpu::kBindOcclusionPyramid, SSBO), b(gpu::kBindCoveredPixels, SSBO),
                                      b(gpu::kBindProperty, SSBO), b(gpu::kBindColor, SSBO)}));
  set.write_buffer(gpu::kBindFrame, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, frame_ubo.get());
  set.write_buffer(gpu::kBindNodes, SSBO, nodes.get());
  set.write_buffer(gpu::kBindMeshlets, SSBO, meshlets_h);
  set.write_buffer(gpu::kBindParticles, SSBO, particles_h);
  set.write_buffer(gpu::kBindTypes, SSBO, types.get());
  set.write_buffer(gpu::kBindDrawList, SSBO, draw_list.get());
  set.write_buffer(gpu::kBindRadii, SSBO, radii_h);
  set.write_buffer(gpu::kBindProperty, SSBO, property_h);
  set.write_buffer(gpu::kBindColor, SSBO, color_h);
  if (!vis_route) set.write_storage_image(gpu::kBindColorImage, color.view());
  write_accumulation_descriptors();
  set.write_buffer(gpu::kBindSprites, SSBO, sprites.get());
  set.write_buffer(gpu::kBindSpriteDraw, SSBO, sprite_draw.get());
  set.write_buffer(gpu::kBindVisibility, SSBO, visibility.get());
  write_occlusion_descriptor();
  const vk::DescriptorSet* sets[] = {&set};
  MDS_ASSIGN_OR_RETURN(layout, ctx->pipelines().layout(sets));
  MDS_ASSIGN_OR_RETURN(draw_list_pipe, ctx->pipelines().compute(layout, "draw_list_all.comp"));
  // Sprites: a compute pre-pass computes every glyph once, the vertex stages only load (on
  // lavapipe vertex processing and primitive setup run mostly on one thread, compute on all).
  // Visibility route (vis_route, see renderer_impl.h): sprites up to kSmallSpritePx pixels are
  // rasterized by compute (all threads) into the visibility buffer -- on lavapipe primitive
  // setup costs about 1 us per glyph on one thread, more than ray casting a few pixels -- and
  // the others are rasterized into the same buffer; visibility_resolve.comp then shades each
  // pixel once and accumulates. The rasterized ones are drawn as point sprites (one vertex and
  // primitive each instead of 4 and 2) where the device supports largePoints (vk/context.cpp
  // enables it whenever supported) and points of at least 8 pixels, else as quads; sprites
  // larger than the point size range are always quads. Attachment route: every sprite is
  // rasterized into colour + depth attachments and accumulate.comp adds the colour.
  // MDSTREAM_SPRITES=quads|points overrides the default, MDSTREAM_SMALL_PX=<pixels> the compute
  // threshold (0: every sprite rasterized).
  // The task/mesh path ray casts glyphs in its mesh stage (sphere.mesh) up to 16 pixels on a CPU
  // device and up to 2 on a GPU. On an NVIDIA H200 (docs/results/gpu-h200.md) loops over up to
  // 16x16 pixels there made its 1920x1080 frames up to 5.4x slower than with 2 pixels (median
  // 3.2x), while the compute path's sprite_raster.comp is fastest at 16. On lavapipe, whose
  // primitive setup runs on one thread, 2 pixels made converged 640x360 frames of 1M particles
  // 1.6-11x the compute path's (docs/results/mesh-path.md has the 16-pixel run).
  constexpr float kSmallSpritePx = 16.0f;
  const float mesh_small_px = ctx->info().type == VK_PHYSICAL_DEVICE_TYPE_CPU ? 16.0f : 2.0f;
  const float max_point = ctx->limits().pointSizeRange[1];
  VkPhysicalDeviceFeatures features{};
  vkGetPhysicalDeviceFeatures(ctx->physical(), &features);
  const bool points_ok = features.largePoints == VK_TRUE && max_point >= 8.0f;
  point_sprites = points_ok;
  if (const char* e = std::getenv("MDSTREAM_SPRITES")) point_sprites = points_ok && std::string(e) == "points";
  small_px = vis_route ? (mesh_path ? mesh_small_px : kSmallSpritePx) : 0.0f;
  if (const char* e = std::getenv("MDSTREAM_SMALL_PX")) small_px = vis_route ? float(std::atof(e)) : 0.0f;
  MDS_ASSIGN_OR_RETURN(sprite_args_pipe, ctx->pipelines().compute(layout, "sprite_args.comp"));
  // Task/mesh sprites where the device has them (--mesh-shaders): no pre-pass records, no
  // points; on the visibility route the mesh stage ray casts the small glyphs itself (the
  // compute rasterization's threshold) and the resolve rebuilds spheres from the particles'
  // frame-wide ids (chunked_ids); sprite_args.comp still sizes the task launch.
  if (mesh_path) {  // decided at creation (use_mesh_sprites), before the draw buffers
    MDS_ASSIGN_OR_RETURN(mesh, MeshSprites::create(*ctx, layout, kColorFormat, kDepthFormat,
                                                   vis_route, small_px,
                                                   settings.cull && settings.particle_occlusion));
    point_sprites = false;
    sprite_read_stages = MeshSprites::kReadStages;
  }
  MDS_TRY(create_accumulate_pipeline());
  if (covered_list) {  // decided with the route (create_targets); a resize keeps it
    MDS_ASSIGN_OR_RETURN(compact_pipe, ctx->pipelines().compute(layout, "visibility_compact.comp"));
  }
  auto prepass = [&](bool particle_occlusion) {  // specialization constant 3: kParticleOcclusion
    vk::SpecConstants spec;
    spec.add(0u, VkBool32(point_sprites)).add(1u, max_point).add(2u, small_px).add(3u, VkBool32(particle_occlusion));
    spec.add(4u, VkBool32(chunked_ids()));  // kChunkedIds: visibility ids by particle, not by record
    return ctx->pipelines().compute(layout, "sphere_prepass.comp", &spec);
  };
  MDS_ASSIGN_OR_RETURN(prepass_pipe, prepass(false));
  if (settings.cull && settings.particle_occlusion) {
    MDS_ASSIGN_OR_RETURN(prepass_occ_pipe, prepass(true));
  }
  if (small_px > 0.0f && !mesh_path) {  // shaderInt64 + 64-bit atomics: only on the visibility route
    MDS_ASSIGN_OR_RETURN(raster_pipe, ctx->pipelines().compute(layout, "sprite_raster.comp"));
  }
  vk::SpecConstants quad_spec;
  quad_spec.add(0u, VkBool32(point_sprites));  // quads come from the quad list
  vk::GraphicsPipelineDesc g;
  g.vertex_shader = "sphere.vert";
  g.vertex_spec = &quad_spec;
  set_pixel_targets(g, "sphere");
  MDS_ASSIGN_OR_RETURN(sphere_pipe, ctx->pipelines().graphics(layout, g));
  cell_pipe = VK_NULL_HANDLE;
  if (settings.cell) MDS_TRY(create_cell_pipeline());
  if (point_sprites) {
    vk::GraphicsPipelineDesc gp = g;
    gp.vertex_shader = "sphere_point.vert";
    gp.vertex_spec = nullptr;
    gp.topology = VK_PRIMITIVE_TOPOLOGY_POINT_LIST;
    MDS_ASSIGN_OR_RETURN(point_pipe, ctx->pipelines().graphics(layout, gp));
  }
  return {};
}

// The fragment stage `name`.frag and the targets of the route: on the visibility route no
// attachments (`name`_vis.frag writes the visibility buffer), else colour and depth.
void Renderer::Impl::set_pixel_targets(vk::GraphicsPipelineDesc& g, const std::string& name) const {
  if (vis_route) {
    g.fragment_shader = name + "_vis.frag";
    g.depth_test = false;
    g.depth_write = false;
  } else {
    g.fragment_shader = name + ".frag";
    g.color_formats = {kColorFormat};
    g.depth_format = kDepthFormat;
  }
}

// The simulation cell's edges (cell_lines.vert): quads into the same targets as the spheres'.
Status Renderer::Impl::create_cell_pipeline() {
  vk::GraphicsPipelineDesc g;
  g.vertex_shader = "cell_lines.vert";
  set_pixel_targets(g, "cell_lines");
  MDS_ASSIGN_OR_RETURN(cell_pipe, ctx->pipelines().graphics(layout, g));
  return {};
}

// --color-by property needs the store's property (store kFlagProperty), --color-by color its
// colours (kFlagColor).
Status check_color_by(const ColorBy& c, bool has_property, bool has_color) {
  if (c.axis < -1 || c.axis > kColorByProperty)
    return make_error(Errc::internal, "--color-by '{}' was not resolved against the store (render::resolve_color_by)",
                      c.name);
  if (c.by_property() && !has_property)
    return make_error(Errc::invalid_argument,
                      "--color-by property: the store has no per-particle property (convert it with --property NAME)");
  if (c.by_color() && !has_color)
    return make_error(Errc::invalid_argument,
                      "--color-by color: the store has no per-particle colours (convert MMPLD or extended XYZ with --color)");
  return {};
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
  MDS_ASSIGN_OR_RETURN(m.mesh_path, use_mesh_sprites(ctx, settings.mesh_shaders));
  m.origin = scene.origin;
  m.bounds = scene.bounds;
  m.clip_bounds = with_cell(m.bounds, settings.cell);
  m.meshlet_count = uint32_t(scene.meshlets.size());
  m.particle_count = scene.particle_count();
  m.max_meshlet = scene.max_meshlet_particles;
  m.flags = scene.per_particle_radius ? gpu::kFramePerParticleRadius : 0u;
  m.radius_min = scene.radius_min;
  m.radius_max = scene.radius_max;
  m.has_property = scene.has_property;
  m.property_min = scene.property_min;
  m.property_max = scene.property_max;
  m.has_color = scene.has_color;
  MDS_TRY(check_color_by(settings.color_by, m.has_property, m.has_color));
  MDS_TRY(m.upload(scene));
  MDS_TRY(m.create_frame_resources());
  if (settings.cull) {
    std::shared_ptr<const culling::DensityVolume> vol = settings.density;
    if (!vol) vol = std::make_shared<culling::DensityVolume>(culling::density_from_scene(scene));
    if (const auto& cs = settings.cull_scene) {
      if (!settings.density || cs->meshlet_slots != scene.meshlets.size() || cs->node_count != scene.nodes.size())
        return make_error(Errc::internal, "RenderSettings::cull_scene: not made from this scene and density volume");
      MDS_TRY(m.create_cull(*cs, *vol));
    } else {
      MDS_TRY(m.create_cull(culling::cull_scene(scene, *vol), *vol));
    }
  }
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
  if (m.cache) return render_streaming(camera_in, stats);
  m.has_view = false;  // the progressive state does not survive a full render
  m.view_coverage = -1;  // the first frame probes the coverage (resolve choice)
  m.coverage_probe_pending = false;
  const auto t0 = std::chrono::steady_clock::now();
  Camera camera = camera_in;
  fit_clip_planes(camera, m.clip_bounds);
  const uint32_t w = m.settings.width, h = m.settings.height;
  vk::TimestampPool fresh;
  MDS_ASSIGN_OR_RETURN(fresh, vk::TimestampPool::create(*m.ctx, m.timestamp_capacity()));
  m.timestamps = std::move(fresh);

  CullStats cs;
  // GPU time per submitted frame (sum of its passes) and what the frame did.
  enum class FrameKind { during_culling, after_convergence, cull_only, timing, paired_culled, paired_all };
  std::vector<double> frame_ms;
  std::vector<std::map<std::string, double>> frame_passes;  // per timed frame: pass -> ms
  std::vector<FrameKind> frame_kind;
  uint32_t quiet = 0;
  const uint32_t max_iterations = m.cull ? std::max(1u, m.cull->settings().max_iterations) : 0u;
  auto collect_frame = [&]() -> Status {
    std::map<std::string, size_t> before;
    for (const auto& [name, v] : m.timestamps.samples()) before[name] = v.size();
    MDS_TRY(m.timestamps.collect());
    double sum = 0.0;
    bool any = false;
    std::map<std::string, double> passes;
    for (const auto& [name, v] : m.timestamps.samples()) {
      for (size_t i = before.count(name) ? before[name] : 0; i < v.size(); ++i)
        sum += v[i], passes[name] += v[i], any = true;
    }
    if (any) {
      frame_ms.push_back(sum);
      frame_passes.push_back(std::move(passes));
    }
    return {};
  };
  auto after_iteration = [&]() {  // the previous submission (with a culling iteration) has completed
    (void)m.cull->collect_route_timings();  // a failed read only keeps the sampling route as it was
    const gpu::CullCounters c = m.cull->counters();
    cs.changed_per_iteration.push_back(c.changed);
    cs.culled_per_iteration.push_back(c.class_count[MDS_CULL_CLASS_O]);
    cs.class_counts.assign(c.class_count, c.class_count + 4);
    cs.node_class_counts.assign(c.node_class_count, c.node_class_count + 4);
    if (m.iteration_hook) m.iteration_hook(m.cull_iteration);
    ++m.cull_iteration;
    quiet = c.changed == 0 ? quiet + 1 : 0;
    if (quiet >= std::max(1u, m.cull->settings().converge_iterations)) {  // Sect. 5.3
      m.cull_active = false;
      cs.converged = true;
      cs.iterations_to_converge = m.cull_iteration;
      cs.samples_to_converge = m.cull_iteration * m.cull->samples_per_iteration();
      cs.time_to_converge_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    } else if (m.cull_iteration >= max_iterations) {
      m.cull_active = false;  // --max-iterations reached: keep the classes, not converged
    }
  };
  if (m.cull) {
    MDS_TRY(m.cull->begin_view(camera));
    m.cull_active = true;
    m.cull_iteration = 0;
  }
  bool pending_iteration = false;
  // Begins the next submission after the previous one completed (its timestamps and counters).
  auto begin_submission = [&]() -> Result<VkCommandBuffer> {
    MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, m.slot.begin());
    MDS_TRY(collect_frame());
    if (pending_iteration) after_iteration();
    m.destroyer.collect(m.frame_index);
    return cmd;
  };
  auto end_submission = [&]() -> Status {
    MDS_TRY(m.slot.submit(m.ctx->queue()));
    ++m.frame_index;
    return {};
  };
  // 1. spp super-sampling frames; while culling is active each also runs one culling iteration.
  for (uint32_t s = 0; s < m.settings.spp; ++s) {
    MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, begin_submission());
    m.write_frame_uniforms(camera, s);
    pending_iteration = m.cull && m.cull_active;
    frame_kind.push_back(pending_iteration ? FrameKind::during_culling : FrameKind::after_convergence);
    m.record_pass(cmd, s == 0);
    MDS_TRY(end_submission());
  }
  // 2. Not converged within spp: culling iterations alone until convergence or max_iterations.
  bool late = false;
  while (m.cull) {
    MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, begin_submission());
    if (!m.cull_active) {
      MDS_TRY(m.slot.submit(m.ctx->queue()));  // empty; keeps begin/submit paired
      break;
    }
    late = true;
    pending_iteration = true;
    frame_kind.push_back(FrameKind::cull_only);
    m.record_cull_only(cmd);
    MDS_TRY(end_submission());
  }
  pending_iteration = false;
  // 3. With RenderSettings::converged_image (and frames of step 1 drawn while the loop was still
  //    culling), the spp frames are drawn again with the final potentially visible set, the
  //    accumulation restarted: the image the viewer shows once the loop has converged. Otherwise,
  //    when the loop converged past spp, a few timing frames of the final set for
  //    frame_ms_after_convergence: every pass of a sampling frame, accumulating with weight 0
  //    (kFrameTimingOnly), so they cost what a sampling frame costs and the image keeps exactly
  //    the spp samples of step 1.
  const bool mixed = std::find(frame_kind.begin(), frame_kind.end(), FrameKind::during_culling) != frame_kind.end();
  if (m.settings.converged_image && m.cull && cs.converged && mixed) {
    for (uint32_t s = 0; s < m.settings.spp; ++s) {
      MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, begin_submission());
      m.write_frame_uniforms(camera, s);
      frame_kind.push_back(FrameKind::after_convergence);
      m.record_pass(cmd, s == 0);
      MDS_TRY(end_submission());
    }
  } else if (late && cs.converged) {
    for (uint32_t s = 0; s < kTimingFrames; ++s) {
      MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, begin_submission());
      m.write_frame_uniforms(camera, m.settings.spp + s, gpu::kFrameTimingOnly);
      frame_kind.push_back(FrameKind::timing);
      m.record_pass(cmd, false, true);
      MDS_TRY(end_submission());
    }
  }
  // 3. Paired frames (RenderSettings::paired_frames, after convergence): every meshlet and the
  //    potentially visible set, alternately, in this process and the same minutes, weight 0. Their
  //    pass times stay out of pass_ms_median.
  std::optional<std::map<std::string, std::vector<double>>> samples_before_paired;
  if (m.cull && cs.converged) {
    for (uint32_t s = 0; s < 2 * m.settings.paired_frames; ++s) {
      MDS_ASSIGN_OR_RETURN(VkCommandBuffer cmd, begin_submission());
      if (!samples_before_paired) samples_before_paired = m.timestamps.samples();
      const bool all = s % 2 == 0;  // ends with a culled frame: read_last_depth() sees the culled image
      m.write_frame_uniforms(camera, m.settings.spp + kTimingFrames + s / 2, gpu::kFrameTimingOnly, all);
      frame_kind.push_back(all ? FrameKind::paired_all : FrameKind::paired_culled);
      m.record_pass(cmd, false, true, all);
      MDS_TRY(end_submission());
    }
  }
  MDS_TRY(m.slot.wait());
  MDS_TRY(collect_frame());
  if (pending_iteration) after_iteration();
  m.rendered = true;
  if (m.cull) {
    cs.enabled = true;
    cs.iterations = m.cull_iteration;
    cs.samples = m.cull_iteration * m.cull->samples_per_iteration();
    cs.samples_per_iteration = m.cull->samples_per_iteration();
    cs.bins = m.cull->bins();
    cs.sample_passes_compute = m.cull->sample_route_passes(culling::SampleRoute::compute);
    cs.sample_passes_raster = m.cull->sample_route_passes(culling::SampleRoute::raster);
    cs.sample_ms_compute = m.cull->sample_route_ms(culling::SampleRoute::compute);
    cs.sample_ms_raster = m.cull->sample_route_ms(culling::SampleRoute::raster);
    cs.shared_box_tests = m.cull->shared_box_tests();
    cs.node_per_subgroup = m.cull->node_per_subgroup();
    cs.shared_cells = m.cull->shared_cells();
    cs.budget = m.cull->budget();
    if (!cs.class_counts.empty()) cs.meshlets_culled = cs.class_counts[MDS_CULL_CLASS_O];
    std::vector<double> during, after, cull_only, paired_culled, paired_all;
    std::map<std::string, std::vector<double>> after_passes;
    for (size_t f = 0; f < frame_ms.size() && f < frame_kind.size(); ++f) {
      switch (frame_kind[f]) {
        case FrameKind::during_culling: during.push_back(frame_ms[f]); break;
        case FrameKind::after_convergence:
        case FrameKind::timing:
          after.push_back(frame_ms[f]);
          for (const auto& [name, ms] : frame_passes[f]) after_passes[name].push_back(ms);
          break;
        case FrameKind::cull_only: cull_only.push_back(frame_ms[f]); break;
        case FrameKind::paired_culled: paired_culled.push_back(frame_ms[f]); break;
        case FrameKind::paired_all: paired_all.push_back(frame_ms[f]); break;
      }
    }
    cs.frame_ms_during_culling = vk::median(during);
    cs.frame_ms_after_convergence = vk::median(after);
    cs.pass_ms_after_convergence.clear();
    for (const auto& [name, v] : after_passes) cs.pass_ms_after_convergence[name] = vk::median(v);
    cs.iteration_ms_without_draw = vk::median(cull_only);
    cs.iterations_after_spp = uint32_t(cull_only.size());
    cs.paired_frames = uint32_t(std::min(paired_culled.size(), paired_all.size()));
    cs.frame_ms_paired_culled = vk::median(paired_culled);
    cs.frame_ms_paired_all = vk::median(paired_all);
    // The particle occlusion test of the last drawn frame, when that frame drew the potentially
    // visible set (after convergence): the pre-pass's counters in the sprite draw header.
    auto last_drawn = std::find_if(frame_kind.rbegin(), frame_kind.rend(),
                                   [](FrameKind k) { return k != FrameKind::cull_only; });
    if (last_drawn != frame_kind.rend() && *last_drawn != FrameKind::during_culling &&
        *last_drawn != FrameKind::paired_all) {  // the pre-pass or the task/mesh stages count
      MDS_ASSIGN_OR_RETURN(auto raw, vk::read_buffer(*m.ctx, m.sprite_draw, 0, sizeof(gpu::SpriteDrawHeader)));
      gpu::SpriteDrawHeader head;
      std::memcpy(&head, raw.data(), sizeof(head));
      cs.particles_listed = head.listed;
      cs.particles_occluded = head.occluded;
    }
  }

  FrameImage img;
  img.width = w;
  img.height = h;
  MDS_ASSIGN_OR_RETURN(img.rgba, m.read_average(m.settings.spp));

  if (stats) {
    stats->device = m.ctx->info().name;
    stats->mesh_sprites = m.mesh_path;
    stats->visibility_route = m.vis_route;
    stats->ambient_occlusion = m.ao_active();
    stats->accumulation_buffer = m.accum_in_buffer;
    stats->covered_pixel_list = m.covered_list && m.last_resolve_listed;
    stats->covered_fraction = m.covered_fraction(w, h);
    stats->sprite_chunks = m.sprite_chunks;
    stats->particles = m.particle_count;
    stats->meshlets = m.meshlet_count;
    stats->spp = m.settings.spp;
    stats->width = w;
    stats->height = h;
    stats->pass_ms_median.clear();
    stats->frame_ms_median = 0.0;
    for (const auto& [name, v] : samples_before_paired ? *samples_before_paired : m.timestamps.samples()) {
      double med = vk::median(v);
      stats->pass_ms_median[name] = med;
      stats->frame_ms_median += med;
    }
    stats->wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    stats->upload_bytes = m.upload_bytes;
    stats->device_bytes = m.ctx->allocator().peak(vk::MemoryIntent::device_local);
    stats->near = camera.near;
    stats->far = camera.far;
    stats->cull = cs;
    MDS_TRY(m.read_sprite_counts(*stats));
  }
  return img;
}

Status Renderer::Impl::read_sprite_counts(RenderStats& s) {
  if (mesh_path) return {};  // no pre-pass: the task/mesh path makes its sprites in place
  MDS_ASSIGN_OR_RETURN(auto raw, vk::read_buffer(*ctx, sprite_draw, 0, sizeof(gpu::SpriteDrawHeader)));
  gpu::SpriteDrawHeader head;
  std::memcpy(&head, raw.data(), sizeof(head));
  s.sprites_listed = head.listed;
  s.sprites_offscreen = head.offscreen;
  s.sprites_small = head.small_total;
  return {};
}

culling::CullLoop* Renderer::cull_loop() { return impl_->cull.get(); }

void Renderer::set_iteration_hook(std::function<void(uint32_t)> hook) { impl_->iteration_hook = std::move(hook); }

Result<std::vector<float>> Renderer::read_last_depth() {
  Impl& m = *impl_;
  if (!m.rendered) return make_error(Errc::internal, "read_last_depth() before render() or step()");
  MDS_TRY(m.slot.wait());  // the frame in flight writes it
  std::vector<float> d(size_t(m.settings.width) * m.settings.height);
  if (m.vis_route) {  // the high word of each pixel's uint64: the nearest depth's bits, all ones = empty
    MDS_ASSIGN_OR_RETURN(std::vector<std::byte> raw, vk::read_buffer(*m.ctx, m.visibility, 0, 8 * d.size()));
    for (size_t i = 0; i < d.size(); ++i) {
      uint64_t v;
      std::memcpy(&v, raw.data() + 8 * i, 8);
      const uint32_t bits = uint32_t(v >> 32);
      float depth = 1.0f;
      if (bits != 0xffffffffu) std::memcpy(&depth, &bits, 4);
      d[i] = depth;
    }
    return d;
  }
  MDS_ASSIGN_OR_RETURN(std::vector<std::byte> raw,
                       vk::read_image(*m.ctx, m.depth, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, 4,
                                      m.settings.width, m.settings.height));
  std::memcpy(d.data(), raw.data(), d.size() * sizeof(float));
  return d;
}

}  // namespace mds::render

