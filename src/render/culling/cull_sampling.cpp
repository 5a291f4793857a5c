// The occlusion sampling pass of the culling loop (paper 000, Sect. 3.2) and its two routes,
// rasterized (shaders/cull_sample.vert/.frag) and compute (shaders/cull_sample.comp), chosen by
// measurement (docs/rendering.md "Occlusion sampling pass").
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <utility>

#include "render/culling/cull_loop_impl.h"

namespace mds::render::culling {

SampleRoute CullLoop::Impl::forced_route() const {
  if (const char* e = std::getenv("MDSTREAM_CULL_SAMPLE")) {
    const std::string v(e);
    if (v == "raster") return SampleRoute::raster;
    if (v == "compute") return SampleRoute::compute;
  }
  return settings.sample_route;
}

bool CullLoop::Impl::sampled_list_wanted() const {
  if (const char* e = std::getenv("MDSTREAM_CULL_UPDATE")) return std::string(e) != "full";
  return settings.sampled_pixel_list;
}

// Automatic route choice (SampleRouteChooser, sample_route.h, decides from the timings): which
// route samples faster depends on the view -- far views with glyphs of a few pixels favour
// compute, close-ups with glyphs of hundreds of pixels the rasterizer's depth test
// (docs/rendering.md). A comparison's passes are timed on the GPU (route_ts) under the route's
// name, a probe's as "<route>_probe" (its time counted probe_share_recorded times), and the
// running route's passes outside a comparison as "run_<route>".
void CullLoop::Impl::begin_route_choice(VkCommandBuffer cmd) {
  if (!compute_available || forced_route() != SampleRoute::automatic) {
    route.stop();
    return;
  }
  route.begin_iteration(moving);
  if (route.times_passes() && route_ts.enabled()) route_ts.reset(cmd);
}

bool CullLoop::Impl::choose_compute_route(uint32_t p, uint32_t pass_count) {
  if (!compute_available) return false;
  const SampleRoute forced = forced_route();
  if (forced != SampleRoute::automatic) return forced == SampleRoute::compute;
  if (!route_ts.enabled()) return true;  // no timestamps on this queue: compute, unmeasured
  return route.pass_route(p, pass_count) == SampleRouteChooser::kCompute;
}

uint32_t CullLoop::Impl::probe_share() const {
  if (const char* e = std::getenv("MDSTREAM_CULL_PROBE_SHARE")) {
    const int v = std::atoi(e);
    if (v >= 1) return uint32_t(v);
  }
  return route.probe_share();
}

bool CullLoop::shared_box_tests() const { return impl_->shared_box_tests; }
bool CullLoop::node_per_subgroup() const { return impl_->nodes_per_group > 0; }
bool CullLoop::shared_cells() const { return impl_->shared_cells; }

uint32_t CullLoop::sample_route_passes(SampleRoute route) const {
  return route == SampleRoute::compute ? impl_->route_passes[1]
                                       : route == SampleRoute::raster ? impl_->route_passes[0] : 0u;
}

CullLoop::SampleRoutes CullLoop::take_sample_routes() { return std::exchange(impl_->routes_since, SampleRoutes{}); }

double CullLoop::sample_route_ms(SampleRoute route) const {
  return route == SampleRoute::compute ? impl_->route.compared_ms(SampleRouteChooser::kCompute)
         : route == SampleRoute::raster ? impl_->route.compared_ms(SampleRouteChooser::kRaster)
                                        : -1.0;
}

Status CullLoop::collect_route_timings() {
  Impl& m = *impl_;
  if (!m.route_ts.enabled() || !m.route.times_passes()) return {};
  std::map<std::string, size_t> before;
  for (const auto& [name, v] : m.route_ts.samples()) before[name] = v.size();
  MDS_TRY(m.route_ts.collect());
  std::vector<SampleRouteChooser::Timing> timings;
  for (const auto& [name, v] : m.route_ts.samples()) {
    using Kind = SampleRouteChooser::Kind;
    const Kind kind = name.starts_with("run_") ? Kind::run : name.ends_with("_probe") ? Kind::probe : Kind::compared;
    const int r = name.find("compute") != std::string::npos ? SampleRouteChooser::kCompute : SampleRouteChooser::kRaster;
    const double scale = kind == Kind::probe ? double(m.probe_share_recorded) : 1.0;
    for (size_t i = before.count(name) ? before[name] : 0; i < v.size(); ++i) timings.push_back({r, kind, scale * v[i]});
  }
  m.route.collect(timings);
  return {};
}

void CullLoop::Impl::record_sampling_pass(VkCommandBuffer cmd, vk::TimestampPool* ts, uint32_t pass,
                                          uint32_t probe_share) {
  auto begin = [&](const char* name) {
    if (ts) ts->begin(cmd, name);
  };
  auto end = [&]() {
    if (ts) ts->end(cmd);
  };
  // The pass's jitter: Halton(2,3) from index 1 (index 0 = pixel centre), in NDC.
  const glm::dvec2 j = halton_jitter(pass + 1);
  const glm::vec2 jitter_ndc(float(2.0 * j.x / width), float(2.0 * j.y / height));

  // select (Sect. 5.2)
  begin("select");
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                              VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
                     VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  gpu::DrawListHeader head{};
  head.index_count = 6 * max_meshlet;
  vkCmdUpdateBuffer(cmd, occluder_list.get(), 0, sizeof(head), &head);
  vkCmdFillBuffer(cmd, counters.get(), offsetof(gpu::CullCounters, selected), 4, 0);
  compute_barrier(cmd);
  bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, select_pipe, set0_sample);
  push(cmd, probe_share, pass);  // cull_select.comp: mode = the budget's divisor (0: the whole budget)
  vk::dispatch_rows(cmd, (meshlet_count + 63) / 64, gpu::kDispatchRow);
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  end();

  // sample (Sect. 3.2): one jittered depth sample per pixel of the occluders.
  begin("sample");
  if (sample_compute) {
    // Clear to all ones (no sample), write the indirect dispatch from the selection's count
    // (mode 1), sample per particle (mode 0).
    vkCmdFillBuffer(cmd, sample_buf.get(), 0, VK_WHOLE_SIZE, 0xFFFFFFFFu);
    compute_barrier(cmd);
    bind(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sample_comp_pipe, set0_sample);
    push(cmd, 1, pass, jitter_ndc);
    vkCmdDispatch(cmd, 1, 1, 1);
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    push(cmd, 0, pass, jitter_ndc);
    vkCmdDispatchIndirect(cmd, occluder_list.get(), offsetof(gpu::DrawListHeader, dispatch_x));
    compute_barrier(cmd);
  } else {
    vk::image_barrier(cmd, sample_image.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                      VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
    vk::image_barrier(cmd, depth.get(), VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
    VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    ca.imageView = sample_image.view();
    ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    ca.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    ca.clearValue.color = {{float(MDS_CULL_DEPTH_EMPTY), 0.0f, 0.0f, 0.0f}};
    VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    da.imageView = depth.view();
    da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    da.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    da.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    da.clearValue.depthStencil = {1.0f, 0};
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {width, height}};
    ri.layerCount = 1;
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
    vkCmdBeginRendering(cmd, &ri);
    vk::set_viewport_scissor(cmd, width, height);
    bind(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, sample_pipe, set0_sample);
    push(cmd, 0, pass, jitter_ndc);
    vkCmdBindIndexBuffer(cmd, indices.get(), 0, VK_INDEX_TYPE_UINT16);
    vkCmdDrawIndexedIndirect(cmd, occluder_list.get(), 0, 1, sizeof(VkDrawIndexedIndirectCommand));
    vkCmdEndRendering(cmd);
    vk::image_barrier(cmd, sample_image.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                      VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                      VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  }
  end();

  if (probe_share > 0) return;  // a probe measures only: its samples are not applied
  begin("update");  // Algorithm 1
  record_update(cmd, pass);
  end();
}

Status CullLoop::run_update_only(const std::vector<glm::vec2>& samples, uint32_t iteration) {
  Impl& m = *impl_;
  // The rasterized route's image unless the compute route is forced (the image is then 1x1).
  m.sample_compute = m.compute_available && m.forced_route() == SampleRoute::compute;
  // The compute route's layout: per pixel (alpha_s bits, view depth bits) as two words.
  std::vector<glm::uvec2> words;
  if (m.sample_compute) {
    words.resize(samples.size());
    for (size_t i = 0; i < samples.size(); ++i) {
      std::memcpy(&words[i].x, &samples[i].y, 4);
      std::memcpy(&words[i].y, &samples[i].x, 4);
    }
  }
  const uint64_t bytes = samples.size() * sizeof(glm::vec2);
  MDS_ASSIGN_OR_RETURN(vk::Buffer staging, vk::Buffer::create(m.ctx->allocator(), bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                                              vk::MemoryIntent::upload, "test samples"));
  std::memcpy(staging.mapped(), m.sample_compute ? static_cast<const void*>(words.data()) : samples.data(), bytes);
  staging.flush();
  m.write_uniforms(iteration);
  return m.ctx->submit_and_wait([&](VkCommandBuffer cmd) {
    if (m.sample_compute) {
      VkBufferCopy c{0, 0, bytes};
      vkCmdCopyBuffer(cmd, staging.get(), m.sample_buf.get(), 1, &c);
      compute_barrier(cmd);
    } else {
      vk::image_barrier(cmd, m.sample_image.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                        VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                        VK_ACCESS_2_TRANSFER_WRITE_BIT);
      VkBufferImageCopy r{};
      r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      r.imageExtent = {m.width, m.height, 1};
      vkCmdCopyBufferToImage(cmd, staging.get(), m.sample_image.get(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &r);
      vk::image_barrier(cmd, m.sample_image.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                        VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                        VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    }
    m.record_update(cmd, iteration);
  });
}

Result<std::vector<glm::vec2>> CullLoop::run_sampling_pass_only(uint32_t pass) {
  Impl& m = *impl_;
  m.sample_compute = m.compute_available && m.forced_route() == SampleRoute::compute;
  m.write_uniforms(pass);
  m.write_frame_uniforms(pass);
  const size_t px = size_t(m.width) * m.height;
  if (m.sample_compute) {
    MDS_TRY(m.ctx->submit_and_wait([&](VkCommandBuffer cmd) { m.record_sampling_pass(cmd, nullptr, pass); }));
    // Per pixel (alpha_s bits, view depth bits) as two words; all ones: no sample.
    MDS_ASSIGN_OR_RETURN(auto words, m.read<glm::uvec2>(m.sample_buf, px));
    std::vector<glm::vec2> out(px, glm::vec2(float(MDS_CULL_DEPTH_EMPTY), 0.0f));
    for (size_t p = 0; p < px; ++p) {
      if (words[p].x == ~0u && words[p].y == ~0u) continue;
      std::memcpy(&out[p].y, &words[p].x, 4);
      std::memcpy(&out[p].x, &words[p].y, 4);
    }
    return out;
  }
  MDS_TRY(m.ctx->submit_and_wait([&](VkCommandBuffer cmd) { m.record_sampling_pass(cmd, nullptr, pass); }));
  MDS_ASSIGN_OR_RETURN(auto raw, vk::read_image(*m.ctx, m.sample_image, VK_IMAGE_LAYOUT_GENERAL,
                                                sizeof(glm::vec2), m.width, m.height));
  std::vector<glm::vec2> out(px);
  std::memcpy(out.data(), raw.data(), px * sizeof(glm::vec2));
  return out;
}

}  // namespace mds::render::culling
