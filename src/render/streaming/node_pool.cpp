// The paged device pool of the streaming cache; see node_pool.h.
#include "render/streaming/node_pool.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "culling/culling_constants.h"
#include "vk/commands.h"

namespace mds::render::streaming_gpu {

uint32_t PoolLayout::pages_for(uint64_t particles, uint64_t meshlets) const {
  const uint64_t by_particles = (particles + page_particles - 1) / page_particles;
  const uint64_t by_meshlets = (meshlets + page_meshlets - 1) / page_meshlets;
  return uint32_t(std::max<uint64_t>({1, by_particles, by_meshlets}));
}

PoolLayout pool_layout_for(const store::FileHeader& h, bool colors) {
  PoolLayout l;
  l.radii = (h.flags & store::kFlagPerParticleRadius) != 0;
  l.property = (h.flags & store::kFlagProperty) != 0;
  l.color = colors && (h.flags & store::kFlagColor) != 0;
  const double mean = h.meshlet_count > 0 ? double(h.particle_count) / double(h.meshlet_count) : 16.0;
  const double slots = std::ceil(1.25 * double(l.page_particles) / std::max(mean, 1.0));
  l.page_meshlets = uint32_t(std::clamp(slots, 8.0, double(l.page_particles)));
  return l;
}

PoolScene pool_scene_for(const store::StoreReader& reader, const PoolLayout& layout, glm::dvec3 origin) {
  const store::FileHeader& h = reader.header();
  PoolScene ps;
  ps.origin = origin;
  for (const auto& t : reader.types()) ps.type_radius.push_back(t.radius);
  ps.per_particle_radius = layout.radii;
  ps.radius_min = h.radius_min;
  ps.radius_max = h.radius_max;
  return ps;
}

NodeFrame node_frame(const store::NodeEntry& e) {
  NodeFrame f;
  for (int a = 0; a < 3; ++a) {
    f.center_min[a] = e.center_min[a];
    f.center_max[a] = e.center_max[a];
  }
  return f;
}

Result<std::unique_ptr<NodePool>> NodePool::create(vk::Context& ctx, const PoolLayout& layout, PoolScene scene,
                                                   uint32_t node_count, uint64_t budget_bytes,
                                                   uint64_t store_pages, uint64_t staging_bytes) {
  std::unique_ptr<NodePool> p(new NodePool());
  p->ctx_ = &ctx;
  p->layout_ = layout;
  p->scene_ = std::move(scene);
  const uint64_t range = ctx.limits().maxStorageBufferRange;
  const uint64_t usable_pages = std::min<uint64_t>(budget_bytes / layout.page_bytes(), store_pages);
  uint64_t pages = usable_pages;
  pages = std::min<uint64_t>(pages, range / (8ull * layout.page_particles));
  pages = std::min<uint64_t>(pages, range / (sizeof(gpu::GpuMeshlet) * layout.page_meshlets));
  pages = std::min<uint64_t>(pages, std::numeric_limits<uint32_t>::max() / layout.page_particles);
  if (pages == 0)
    return make_error(Errc::budget, "--gpu-budget {} is smaller than one pool page ({})", format_bytes(budget_bytes),
                      format_bytes(layout.page_bytes()));
  p->pages_ = uint32_t(pages);
  p->device_capped_ = pages < usable_pages;
  p->budget_ = mds::streaming::DeviceBudget(pages * layout.page_bytes());
  p->free_.resize(pages);
  for (uint32_t i = 0; i < pages; ++i) p->free_[i] = uint32_t(pages - 1 - i);  // page 0 popped first
  p->node_pages_.resize(node_count);

  auto& alloc = ctx.allocator();
  const VkBufferUsageFlags ssbo =
      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  const uint64_t slots = pages * layout.page_particles, mslots = pages * layout.page_meshlets;
  MDS_ASSIGN_OR_RETURN(p->particles_, vk::Buffer::create(alloc, slots * 8, ssbo, vk::MemoryIntent::device_local,
                                                         "pool: particles"));
  MDS_ASSIGN_OR_RETURN(p->radii_, vk::Buffer::create(alloc, layout.radii ? slots * 2 : 16, ssbo,
                                                     vk::MemoryIntent::device_local, "pool: radii"));
  MDS_ASSIGN_OR_RETURN(p->property_, vk::Buffer::create(alloc, layout.property ? slots * 2 : 16, ssbo,
                                                        vk::MemoryIntent::device_local, "pool: property"));
  MDS_ASSIGN_OR_RETURN(p->color_, vk::Buffer::create(alloc, layout.color ? slots * 4 : 16, ssbo,
                                                     vk::MemoryIntent::device_local, "pool: colours"));
  MDS_ASSIGN_OR_RETURN(p->meshlets_, vk::Buffer::create(alloc, mslots * sizeof(gpu::GpuMeshlet), ssbo,
                                                        vk::MemoryIntent::device_local, "pool: meshlet records"));
  MDS_ASSIGN_OR_RETURN(p->classes_, vk::Buffer::create(alloc, mslots * 4, ssbo, vk::MemoryIntent::device_local,
                                                       "pool: meshlet classes"));
  MDS_ASSIGN_OR_RETURN(p->staging_buf_, vk::Buffer::create(alloc, std::max<uint64_t>(staging_bytes, 1 << 16),
                                                           VK_BUFFER_USAGE_TRANSFER_SRC_BIT, vk::MemoryIntent::upload,
                                                           "pool: upload staging"));
  p->staging_ = {static_cast<std::byte*>(p->staging_buf_.mapped()), size_t(p->staging_buf_.size())};
  static_assert(MDS_CULL_CLASS_P == 0, "classes are reset to P by copying zeros");
  // kZeroPages pages' meshlet records of zeros: 16 x 32 slots x 48 B = 24 KiB at the default page.
  MDS_ASSIGN_OR_RETURN(p->zeros_, vk::Buffer::create(alloc, uint64_t(kZeroPages) * layout.page_meshlets * sizeof(gpu::GpuMeshlet),
                                                     VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                     vk::MemoryIntent::device_local, "pool: zeros"));
  p->page_pending_.assign(pages, 0);
  // Every slot starts empty (particle_count 0).
  MDS_TRY(ctx.submit_and_wait([&](VkCommandBuffer cmd) {
    vkCmdFillBuffer(cmd, p->meshlets_.get(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, p->classes_.get(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, p->particles_.get(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, p->radii_.get(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, p->property_.get(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, p->color_.get(), 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(cmd, p->zeros_.get(), 0, VK_WHOLE_SIZE, 0);
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  }));
  return p;
}

NodePool::~NodePool() = default;

void coalesce_copies(std::vector<VkBufferCopy>& regions) {
  size_t out = 0;
  for (size_t i = 0; i < regions.size(); ++i) {
    if (out > 0) {
      VkBufferCopy& last = regions[out - 1];
      if (last.srcOffset + last.size == regions[i].srcOffset && last.dstOffset + last.size == regions[i].dstOffset) {
        last.size += regions[i].size;
        continue;
      }
    }
    regions[out++] = regions[i];
  }
  regions.resize(out);
}

uint32_t NodePool::take_copy_regions() { return std::exchange(copy_regions_, 0u); }

void NodePool::begin_frame() {
  staging_head_ = 0;
  transfers_ = false;
  flushed_ = false;
}

Status NodePool::evict(VkCommandBuffer cmd, uint32_t node) {
  if (node >= node_pages_.size() || node_pages_[node].empty())
    return make_error(Errc::internal, "pool: evict of node {} which is not resident", node);
  const uint64_t rec = layout_.page_meshlets * sizeof(gpu::GpuMeshlet);
  // A node placed earlier in this frame: its copies go first, so that the zeros land after them.
  for (uint32_t page : node_pages_[node])
    if (page_pending_[page]) {
      flush(cmd);
      break;
    }
  const std::vector<uint32_t>& pages = node_pages_[node];
  for (size_t j = 0; j < pages.size(); ++j) zero_meshlets_.push_back({(j % kZeroPages) * rec, uint64_t(pages[j]) * rec, rec});
  // Freed last page first, so that the stack hands them out again in ascending order: a node
  // placed in them gets contiguous pages, whose copies merge (coalesce_copies).
  for (auto it = pages.rbegin(); it != pages.rend(); ++it) free_.push_back(*it);
  MDS_TRY(budget_.release(uint64_t(node_pages_[node].size()) * layout_.page_bytes()));
  node_pages_[node].clear();
  transfers_ = true;
  return {};
}

void NodePool::flush(VkCommandBuffer cmd) {
  const bool copies = !copy_particles_.empty() || !copy_meshlets_.empty() || !zero_classes_.empty();
  if (zero_meshlets_.empty() && !copies) return;
  auto transfer_barrier = [&] {
    vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  };
  if (flushed_) transfer_barrier();  // after this frame's earlier copies to the same pages
  auto record = [&](VkBuffer src, VkBuffer dst, std::vector<VkBufferCopy>& regions) {
    coalesce_copies(regions);
    if (!regions.empty()) vkCmdCopyBuffer(cmd, src, dst, uint32_t(regions.size()), regions.data());
    copy_regions_ += uint32_t(regions.size());
    regions.clear();
  };
  if (!zero_meshlets_.empty()) {
    record(zeros_.get(), meshlets_.get(), zero_meshlets_);
    if (copies) transfer_barrier();  // a page emptied here may be written below
  }
  record(staging_buf_.get(), particles_.get(), copy_particles_);
  record(staging_buf_.get(), radii_.get(), copy_radii_);
  record(staging_buf_.get(), property_.get(), copy_property_);
  record(staging_buf_.get(), color_.get(), copy_color_);
  record(staging_buf_.get(), meshlets_.get(), copy_meshlets_);
  record(zeros_.get(), classes_.get(), zero_classes_);
  for (uint32_t page : pending_pages_) page_pending_[page] = 0;
  pending_pages_.clear();
  flushed_ = true;
}

uint64_t NodePool::upload_bytes(const store::NodeData& d) const {
  return d.particle_count() * (8 + (layout_.radii ? 2 : 0) + (layout_.property ? 2 : 0) + (layout_.color ? 4 : 0)) +
         d.meshlet_size.size() * sizeof(gpu::GpuMeshlet) + 80;  // + the 16-byte alignment of up to 5 arrays (< 80)
}

Status meshlet_bounds(const PoolScene& scene, uint32_t node, const NodeFrame& frame, const store::NodeData& d,
                      std::vector<float>& out) {
  const uint64_t n = d.particle_count(), m = d.meshlet_size.size();
  if (d.qpos.size() != 3 * n || d.type_index.size() != n || (scene.per_particle_radius && d.radius_q.size() != n))
    return make_error(Errc::format, "node {}: {} particles, {} coordinates, {} types: inconsistent", node, n,
                      d.qpos.size(), d.type_index.size());
  double step[3];
  for (int a = 0; a < 3; ++a) step[a] = (frame.center_max[a] - frame.center_min[a]) / double(store::kQuantMax);
  out.resize(6 * m);
  uint64_t p = 0;
  for (uint64_t k = 0; k < m; ++k) {
    const uint32_t count = d.meshlet_size[k];
    if (count == 0 || p + count > n)
      return make_error(Errc::format, "node {} meshlet {}: size {} overruns the node's {} particles", node, k, count, n);
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (uint64_t i = p; i < p + count; ++i) {
      glm::vec3 pos;
      for (int a = 0; a < 3; ++a)
        pos[a] = float(frame.center_min[a] + double(d.qpos[3 * i + a]) * step[a] - scene.origin[a]);
      const uint8_t t = d.type_index[i];
      if (t >= scene.type_radius.size())
        return make_error(Errc::format, "node {} particle {}: type index {} outside the type table ({} types)", node,
                          i, t, scene.type_radius.size());
      const float r = scene.per_particle_radius
                          ? float(scene.radius_min + double(d.radius_q[i]) * (scene.radius_max - scene.radius_min) /
                                                         store::kQuantMax)
                          : scene.type_radius[t];
      lo = glm::min(lo, pos - r);
      hi = glm::max(hi, pos + r);
    }
    for (int a = 0; a < 3; ++a) {
      out[6 * k + a] = lo[a];
      out[6 * k + 3 + a] = hi[a];
    }
    p += count;
  }
  if (p != n) return make_error(Errc::format, "node {}: meshlet sizes sum to {}, node has {} particles", node, p, n);
  return {};
}

void pack_particles(const store::NodeData& d, std::vector<uint16_t>& out) {
  const size_t n = d.particle_count();
  out.resize(4 * n);
  for (size_t i = 0; i < n; ++i) {
    out[4 * i + 0] = d.qpos[3 * i + 0];
    out[4 * i + 1] = d.qpos[3 * i + 1];
    out[4 * i + 2] = d.qpos[3 * i + 2];
    out[4 * i + 3] = d.type_index[i];
  }
}

Status NodePool::upload(uint32_t node, const NodeFrame& frame, const store::NodeData& d,
                        std::span<const float> bounds, std::span<const uint16_t> particles) {
  const uint64_t n = d.particle_count(), m = d.meshlet_size.size();
  if (node >= node_pages_.size() || !node_pages_[node].empty())
    return make_error(Errc::internal, "pool: upload of node {} which is resident or out of range", node);
  if (n == 0 || m == 0 || d.qpos.size() != 3 * n || d.type_index.size() != n || (layout_.radii && d.radius_q.size() != n) ||
      (layout_.property && d.property_q.size() != n) || (layout_.color && d.color.size() != n))
    return make_error(Errc::format, "node {}: {} particles, {} meshlets, {} coordinates: inconsistent", node, n, m,
                      d.qpos.size());
  const uint32_t need = layout_.pages_for(n, m);
  const uint64_t bytes = uint64_t(need) * layout_.page_bytes();
  if (need > free_.size() || !budget_.fits(bytes))
    return make_error(Errc::budget, "pool: node {} needs {} pages, {} free", node, need, free_.size());
  const uint64_t staged = upload_bytes(d);
  if (staged > staging_free())
    return make_error(Errc::budget, "pool: node {} needs {} staging bytes, {} left this frame", node, staged,
                      staging_free());
  std::vector<float> computed;
  if (bounds.size() != 6 * m) {  // not prepared by the caller (it validates the meshlet sizes)
    MDS_TRY(meshlet_bounds(scene_, node, frame, d, computed));
    bounds = computed;
  }
  std::vector<uint16_t> packed;
  if (particles.size() != 4 * n) {  // not prepared by the caller
    pack_particles(d, packed);
    particles = packed;
  }

  // The staging area: particles (uint16 x, y, z, type), radii, meshlet records; one copy region
  // per page, recorded by flush(). The meshlet records are written straight into it, each built
  // whole and copied (host-visible upload memory may be write-combined); they validate the
  // meshlet sizes, and an inconsistent node takes its pages and staging back.
  std::byte* base = staging_.data();
  const uint64_t staging_mark = staging_head_;
  auto reserve = [&](uint64_t size) {
    const uint64_t off = staging_head_;
    staging_head_ += (size + 15) & ~uint64_t(15);
    return off;
  };
  const uint64_t part_off = reserve(n * 8);
  const uint64_t rad_off = layout_.radii ? reserve(n * 2) : 0;
  const uint64_t prop_off = layout_.property ? reserve(n * 2) : 0;
  const uint64_t color_off = layout_.color ? reserve(n * 4) : 0;
  const uint64_t rec_off = reserve(m * sizeof(gpu::GpuMeshlet));
  std::vector<uint32_t>& pages = node_pages_[node];  // the last `need` free pages, last first
  pages.assign(free_.rbegin(), free_.rbegin() + need);
  const uint32_t P = layout_.page_particles, M = layout_.page_meshlets;
  auto slot_of = [&](uint64_t local) { return uint64_t(pages[local / P]) * P + local % P; };
  uint64_t p = 0;
  for (uint64_t k = 0; k < m; ++k) {
    const uint32_t count = d.meshlet_size[k];
    if (count == 0 || p + count > n || count > P) {
      staging_head_ = staging_mark;
      pages.clear();
      return make_error(Errc::format, "node {} meshlet {}: size {} overruns the node's {} particles", node, k, count, n);
    }
    gpu::GpuMeshlet g{};
    g.node = node;
    g.particle_count = count;
    g.first_particle = uint32_t(slot_of(p));
    const uint64_t room = P - p % P;  // slots left on the first particle's page
    g.split = uint32_t(std::min<uint64_t>(count, room));
    g.second_particle = count > room ? uint32_t(slot_of(p + room)) : 0u;
    g.aabb_min = glm::vec3(bounds[6 * k + 0], bounds[6 * k + 1], bounds[6 * k + 2]);
    g.aabb_max = glm::vec3(bounds[6 * k + 3], bounds[6 * k + 4], bounds[6 * k + 5]);
    std::memcpy(base + rec_off + k * sizeof(gpu::GpuMeshlet), &g, sizeof(g));
    p += count;
  }
  if (p != n) {
    staging_head_ = staging_mark;
    pages.clear();
    return make_error(Errc::format, "node {}: meshlet sizes sum to {}, node has {} particles", node, p, n);
  }

  // Commit.
  if (Status st = budget_.reserve(bytes, "node pages"); !st.ok()) {  // fits() said it would
    staging_head_ = staging_mark;
    pages.clear();
    return st;
  }
  free_.resize(free_.size() - need);
  std::memcpy(base + part_off, particles.data(), n * 8);
  if (layout_.radii) std::memcpy(base + rad_off, d.radius_q.data(), n * 2);
  if (layout_.property) std::memcpy(base + prop_off, d.property_q.data(), n * 2);
  if (layout_.color) std::memcpy(base + color_off, d.color.data(), n * 4);
  for (uint32_t i = 0; i < need; ++i) {
    const uint64_t first = uint64_t(i) * P, count = first < n ? std::min<uint64_t>(P, n - first) : 0;
    if (count > 0) {
      copy_particles_.push_back({part_off + first * 8, uint64_t(pages[i]) * P * 8, count * 8});
      if (layout_.radii) copy_radii_.push_back({rad_off + first * 2, uint64_t(pages[i]) * P * 2, count * 2});
      if (layout_.property) copy_property_.push_back({prop_off + first * 2, uint64_t(pages[i]) * P * 2, count * 2});
      if (layout_.color) copy_color_.push_back({color_off + first * 4, uint64_t(pages[i]) * P * 4, count * 4});
    }
    const uint64_t mfirst = uint64_t(i) * M, mcount = mfirst < m ? std::min<uint64_t>(M, m - mfirst) : 0;
    if (mcount > 0) {
      const uint64_t rs = sizeof(gpu::GpuMeshlet);
      copy_meshlets_.push_back({rec_off + mfirst * rs, uint64_t(pages[i]) * M * rs, mcount * rs});
      zero_classes_.push_back({(i % kZeroPages) * M * 4, uint64_t(pages[i]) * M * 4, mcount * 4});
    }
    page_pending_[pages[i]] = 1;
    pending_pages_.push_back(pages[i]);
  }
  transfers_ = true;
  return {};
}

void NodePool::end_frame(VkCommandBuffer cmd) {
  if (!transfers_) return;
  flush(cmd);
  staging_buf_.flush();
  vk::memory_barrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                         VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                         VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
  transfers_ = false;
}

}  // namespace mds::render::streaming_gpu
