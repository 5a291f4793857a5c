// Command recording of one frame of the in-memory and streaming renderer: the sprite pre-pass
// (draw list -> sprite records and draw commands, or the task/mesh launch size), the small-sprite
// raster, the sprite draws, a culling iteration alone, and the whole pass (record_pass: clears,
// culling iteration, draw list, sprites, resolve/accumulate) with its GPU timestamps.
// Resources and pipelines are created in renderer.cpp; see renderer_impl.h.
#include <algorithm>
#include <cstddef>

#include "gpu_types.h"
#include "render/renderer_impl.h"
#include "vk/commands.h"
#include "vk/pipeline.h"

namespace mds::render {

// The sprite_draw header's chunk counter to 0 (before a frame's first run of sprite_args.comp),
// after the previous frame's reads of the header.
static void zero_chunk_counter(VkCommandBuffer cmd, VkBuffer sprite_draw) {
  vkCmdFillBuffer(cmd, sprite_draw, offsetof(gpu::SpriteDrawHeader, chunk_next), sizeof(uint32_t), 0u);
}

// The draw list (DrawListHeader.instance_count meshlet ids, written by a compute pass and made
// visible to compute reads) -> sprite records and the sprite draw commands of chunk `chunk`.
void Renderer::Impl::record_sprite_prepass(VkCommandBuffer cmd, uint32_t chunk) {
  VkDescriptorSet ds = set.set();
  if (mesh_path) {  // only the launch size: ceil(list / kMeshTaskMeshlets) task workgroups
    // The previous frame's launch and its counters (task/mesh atomics on the header) are done
    // before the header is rewritten.
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT |
                                sprite_read_stages,
                       VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                           VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                           VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    zero_chunk_counter(cmd, sprite_draw.get());
    if (vis_route) {  // an empty visibility buffer and covered-pixel list, after the last frame's
                      // mesh-stage and fragment atomics and its resolve
      vk::memory_barrier(cmd, MeshSprites::kVisibilityWriteStages | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                         VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
      vkCmdFillBuffer(cmd, visibility.get(), 0, VK_WHOLE_SIZE, gpu::kVisEmpty);
      if (covered_list) {
        const gpu::CoveredPixelsHeader head{gpu::kCoveredGroupsX, 0u, 1u, 0u};
        vkCmdUpdateBuffer(cmd, covered.get(), 0, sizeof(head), &head);
      }
      vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         MeshSprites::kVisibilityWriteStages | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                         VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    }
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sprite_args_pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &ds, 0, nullptr);
    vkCmdDispatch(cmd, 1, 1, 1);
    // The launch size, and the zeroed counters the task/mesh stages add to.
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | sprite_read_stages,
                       VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                           VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    return;
  }
  // The previous chunk's or frame's reads of the sprites and commands (draw, raster, resolve) are
  // done before they are rewritten.
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                              VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  if (chunk == 0) {
    // The chunk counter, and (visibility route) an empty visibility buffer and covered-pixel list,
    // after the previous frame's resolve and draws read them.
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT |
                                VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                           VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT,
                       VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    zero_chunk_counter(cmd, sprite_draw.get());
    if (vis_route) {
      vkCmdFillBuffer(cmd, visibility.get(), 0, VK_WHOLE_SIZE, gpu::kVisEmpty);
      if (covered_list) {
        const gpu::CoveredPixelsHeader head{gpu::kCoveredGroupsX, 0u, 1u, 0u};
        vkCmdUpdateBuffer(cmd, covered.get(), 0, sizeof(head), &head);
      }
    }
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  } else if (vis_route) {
    // The previous chunk's fragment atomics on the visibility buffer before this chunk's compute
    // rasterization.
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  }
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sprite_args_pipe);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &ds, 0, nullptr);
  vkCmdDispatch(cmd, 1, 1, 1);
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                         VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, particle_test ? prepass_occ_pipe : prepass_pipe);
  vkCmdDispatchIndirect(cmd, sprite_draw.get(), offsetof(gpu::SpriteDrawHeader, dispatch_x));
  // Sprites and commands to the draw and to the compute rasterization.
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                         VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                         VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
}

// Visibility route: the small sprites the pre-pass listed, rasterized in compute into the
// visibility buffer (one thread per sprite, sprite_raster.comp).
void Renderer::Impl::record_small_raster(VkCommandBuffer cmd) {
  if (raster_pipe == VK_NULL_HANDLE) return;
  VkDescriptorSet ds = set.set();
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, raster_pipe);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &ds, 0, nullptr);
  vkCmdDispatchIndirect(cmd, sprite_draw.get(), offsetof(gpu::SpriteDrawHeader, raster_x));
  // Its atomics before the rasterized sprites' atomics on the same pixels.
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
}

// Inside a rendering scope: the sprites the pre-pass did not rasterize, as points (when
// enabled) and quads (or the task/mesh path).
void Renderer::Impl::record_sprite_draws(VkCommandBuffer cmd) {
  VkDescriptorSet ds = set.set();
  if (mesh_path) {
    mesh.record_draw(cmd, ds, sprite_draw.get(), offsetof(gpu::SpriteDrawHeader, dispatch_x), particle_test);
    return;
  }
  if (point_sprites) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, point_pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &ds, 0, nullptr);
    vkCmdDrawIndirect(cmd, sprite_draw.get(), offsetof(gpu::SpriteDrawHeader, point_vertex_count), 1,
                      sizeof(VkDrawIndirectCommand));
  }
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, sphere_pipe);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &ds, 0, nullptr);
  vkCmdDrawIndirect(cmd, sprite_draw.get(), offsetof(gpu::SpriteDrawHeader, quad_vertex_count), 1,
                    sizeof(VkDrawIndirectCommand));
}

// One rendering scope of the sprite draws (record_sprite_draws). Attachment route: colour and
// depth cleared when `clear` (a frame's first chunk), else kept from the previous chunk's scope.
// The `last` chunk's scope also draws the simulation cell's edges (cell_lines.vert), depth tested
// against every sphere of the frame.
void Renderer::Impl::record_draw_scope(VkCommandBuffer cmd, bool clear, bool last) {
  const uint32_t w = settings.width, h = settings.height;
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {w, h}};
  ri.layerCount = 1;
  VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  if (!vis_route) {
    if (clear) {
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
    } else {  // the previous chunk's colour and depth writes before this chunk's tests and blends
      vk::image_barrier(cmd, color.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                        VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                        VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                        VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
      vk::image_barrier(cmd, depth.get(), VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                        VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                        VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
    }
    const VkAttachmentLoadOp load = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
    ca.imageView = color.view();
    ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    ca.loadOp = load;
    ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    ca.clearValue.color = {{0.0f, 0.0f, 0.0f, 0.0f}};  // uncovered: nothing (read_average composes the background)
    da.imageView = depth.view();
    da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    da.loadOp = load;
    da.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    da.clearValue.depthStencil = {1.0f, 0};
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
  }
  vkCmdBeginRendering(cmd, &ri);
  vk::set_viewport_scissor(cmd, w, h);
  record_sprite_draws(cmd);
  if (last && cell_pipe != VK_NULL_HANDLE) {
    VkDescriptorSet ds = set.set();
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, cell_pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &ds, 0, nullptr);
    vkCmdDraw(cmd, 6 * 12, 1, 0, 0);  // 12 edges, a quad (6 vertices) each
  }
  vkCmdEndRendering(cmd);
}

// A culling iteration without drawing (iterations after the spp frames, until convergence).
void Renderer::Impl::record_cull_only(VkCommandBuffer cmd) {
  timestamps.reset(cmd);
  cull->record_iteration(cmd, &timestamps, cull_iteration);
}

void Renderer::Impl::record_pass(VkCommandBuffer cmd, bool first, bool accumulate, bool all_meshlets) {
  const uint32_t w = settings.width, h = settings.height;
  VkDescriptorSet ds = set.set();
  if (!timestamps_reset) timestamps.reset(cmd);  // step() resets before the pool's transfers
  timestamps_reset = false;
  if (first) {  // both accumulation targets to zero (the unused one is 16 bytes or 1 pixel)
    vk::image_barrier(cmd, accum.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL,
                      VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                           VK_ACCESS_2_TRANSFER_READ_BIT,
                       VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    VkClearColorValue zero{};
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, accum.get(), VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
    vkCmdFillBuffer(cmd, accum_buf.get(), 0, VK_WHOLE_SIZE, 0u);
    vk::image_barrier(cmd, accum.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_GENERAL,
                      VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  }

  // 0. One culling iteration (select, sample, update, pyramid, classify, histogram) until converged.
  if (cull && cull_active) cull->record_iteration(cmd, &timestamps, cull_iteration);

  // 1. Draw list (no cull: every meshlet; cull: every meshlet not in O).
  timestamps.begin(cmd, "draw_list");
  gpu::DrawListHeader head{};
  head.index_count = 6 * max_meshlet;
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | sprite_read_stages,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
                     VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  vkCmdUpdateBuffer(cmd, draw_list.get(), 0, sizeof(head), &head);
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  if (cull && !all_meshlets) {
    cull->record_draw_list(cmd);  // the potentially visible set: every meshlet not in O
  } else {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, draw_list_pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &ds, 0, nullptr);
    vk::dispatch_rows(cmd, (meshlet_count + 63) / 64, gpu::kDispatchRow);
  }
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | sprite_read_stages,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  timestamps.end(cmd);

  // 2.-3. Per chunk of the draw list (one unless the sprite records hold fewer sprites than the
  //    list has particles; gpu_types.h SpriteDrawHeader, "Chunks"): its sprites, then the small
  //    ones rasterized in compute, then the others drawn -- into the visibility buffer (visibility
  //    route, no attachments) or into colour + depth (attachment route; the first chunk clears
  //    them, the later ones draw over what the earlier ones left). Timestamps per pass with one
  //    chunk; with several, one "sprites" span over all of them (a pass's median stays a
  //    per-frame figure).
  const bool one_chunk = sprite_chunks == 1;
  auto timed = [&](const char* pass, auto&& record) {
    if (one_chunk) timestamps.begin(cmd, pass);
    record();
    if (one_chunk) timestamps.end(cmd);
  };
  if (!one_chunk) timestamps.begin(cmd, "sprites");
  for (uint32_t chunk = 0; chunk < sprite_chunks; ++chunk) {
    timed("prepass", [&] { record_sprite_prepass(cmd, chunk); });
    if (raster_pipe != VK_NULL_HANDLE) timed("raster", [&] { record_small_raster(cmd); });
    timed("draw", [&] { record_draw_scope(cmd, chunk == 0, chunk + 1 == sprite_chunks); });
  }
  if (!one_chunk) timestamps.end(cmd);

  if (!accumulate) return;  // progressive API: the image already holds spp samples

  // 4. Visibility route: "resolve" shades each pixel's nearest sprite once and accumulates.
  //    Attachment route: "accumulate" adds the colour attachment.
  timestamps.begin(cmd, vis_route ? "resolve" : "accumulate");
  if (vis_route) {
    const VkPipelineStageFlags2 writers = mesh_path ? MeshSprites::kVisibilityWriteStages
                                                    : VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    vk::memory_barrier(cmd, writers | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  } else {
    vk::image_barrier(cmd, color.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                      VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                      VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  }
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &ds, 0, nullptr);
  if (coverage_probe_pending) {  // the previous frame (complete: the slot waited) counted
    coverage_rb.invalidate();
    uint32_t count = 0;
    std::memcpy(&count, coverage_rb.mapped(), sizeof(count));
    view_coverage = count;
    coverage_probe_pending = false;
  }
  const bool list_now = covered_list && (view_coverage < 0 || double(view_coverage) <
                                                                  settings.covered_list_max_coverage * double(w) * h);
  last_resolve_listed = list_now;
  if (list_now) {  // list the covered pixels, then shade those (one indirect thread each)
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, compact_pipe);
    vkCmdDispatch(cmd, (w + 15) / 16, (h + 15) / 16, 1);
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve_pipe);
    vkCmdDispatchIndirect(cmd, covered.get(), offsetof(gpu::CoveredPixelsHeader, dispatch_x));
    if (view_coverage < 0) {  // the view's probe: its count to the host
      vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
      const VkBufferCopy region{offsetof(gpu::CoveredPixelsHeader, count), 0, sizeof(uint32_t)};
      vkCmdCopyBuffer(cmd, covered.get(), coverage_rb.get(), 1, &region);
      vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
      coverage_probe_pending = true;
    }
  } else {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, vis_route ? full_resolve_pipe : accum_pipe);
    const uint32_t tile = vis_route ? 16 : 8;  // the shaders' local size
    vkCmdDispatch(cmd, (w + tile - 1) / tile, (h + tile - 1) / tile, 1);
  }
  timestamps.end(cmd);
}

}  // namespace mds::render
