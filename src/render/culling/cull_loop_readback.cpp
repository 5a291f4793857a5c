// The culling loop's state read back and written directly (see cull_loop.h): meshlet classes,
// histograms, pixel state, pyramid and density volume, for the parity tests against the CPU
// reference (src/culling/), `render --stats` and the viewer's debug views.
#include <cstring>

#include "render/culling/cull_loop_impl.h"

namespace mds::render::culling {

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
