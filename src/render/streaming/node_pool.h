// The device pool of the streaming cache (issue 4): every byte of particle payload on the GPU lives
// in fixed-size pages of ONE pool, sized once from --gpu-budget and accounted by one
// streaming::DeviceBudget. A page holds kPageParticles particle slots (uint16 x, y, z, type; plus
// a uint16 radius with per-particle radii) and page_meshlets meshlet slots (GpuMeshlet + class).
// A resident node occupies pages_for(particles, meshlets) pages, not necessarily adjacent: its
// particles fill the pages in order, so a meshlet may continue on the node's next page
// (GpuMeshlet.split / second_particle), and the page count follows from the node directory alone
// (NodeEntry counts), before the node is read: the cache can plan evictions exactly.
// Pages are reused without compaction (no fragmentation: any free page fits any node's need).
// Uploads and evictions are recorded into the frame's command buffer as copy regions (from a
// per-frame staging area; from a buffer of zeros to empty meshlet slots and to reset classes to
// P = 0), gathered over the frame and recorded as one vkCmdCopyBuffer per destination buffer
// (flush(): evictions' zeros, a barrier, the uploads' copies). With one small command per page
// the H200 spent 0.35 ms of untimed GPU time on a frame placing ~65 nodes of the ablation 1M
// jumps, 0.12 ms batched (docs/streaming.md, "Placing a node"). A frame's staging area is reused by the next frame only after the renderer waited
// for the previous one (one frame in flight).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "core/result.h"
#include "gpu_types.h"
#include "store/format.h"
#include "store/store_reader.h"
#include "streaming/budget.h"
#include "vk/context.h"
#include "vk/memory.h"

namespace mds::render::streaming_gpu {

// 512 particle slots per page: 512 * 8 B = 4 KiB of positions+types (+1 KiB of radii); a node of
// 10^4 particles spans 20 pages and wastes at most one partly filled page (< 5 % at 10^4).
inline constexpr uint32_t kPageParticles = 512;
// Pages of zeros the evictions and class resets copy from: the i-th page of a node from zeros
// page i mod kZeroPages, so that a node's contiguous pages take one region (coalesce_copies).
inline constexpr uint32_t kZeroPages = 16;

struct PoolLayout {
  uint32_t page_particles = kPageParticles;
  uint32_t page_meshlets = 32;  // meshlet slots per page (from the store's mean meshlet size)
  bool radii = false;           // per-particle radii stored
  bool property = false;        // the per-particle property stored (store kFlagProperty: + 1 KiB a page)
  bool color = false;           // the per-particle colours stored (store kFlagColor, where drawn: + 2 KiB a page)

  uint64_t particle_bytes() const {
    return uint64_t(page_particles) * (8 + (radii ? 2 : 0) + (property ? 2 : 0) + (color ? 4 : 0));
  }
  uint64_t meshlet_bytes() const { return uint64_t(page_meshlets) * (sizeof(gpu::GpuMeshlet) + 4); }
  uint64_t page_bytes() const { return particle_bytes() + meshlet_bytes(); }
  uint32_t pages_for(uint64_t particles, uint64_t meshlets) const;
  uint64_t node_bytes(uint64_t particles, uint64_t meshlets) const { return pages_for(particles, meshlets) * page_bytes(); }
};
// page_meshlets = kPageParticles / mean meshlet size of the store, rounded up, +25 % (so that the
// particle slots, not the meshlet slots, bound a typical node), at least 8.
// colors: hold the store's per-particle colours (kFlagColor; StreamSettings::colors).
PoolLayout pool_layout_for(const store::FileHeader& header, bool colors = false);

// Scene-wide decoding parameters of meshlet bounds (as render::append_node computes them).
struct PoolScene {
  glm::dvec3 origin{0.0};
  std::vector<float> type_radius;
  bool per_particle_radius = false;
  float radius_min = 0.0f, radius_max = 0.0f;
};

struct NodeFrame {  // a node's quantization frame (NodeEntry center_min / center_max)
  double center_min[3] = {0, 0, 0};
  double center_max[3] = {0, 0, 0};
};

// A store's pool scene: its type radii and radius range, the per-particle radius flag of
// `layout`, positions relative to `origin` (the renderer's).
PoolScene pool_scene_for(const store::StoreReader& reader, const PoolLayout& layout, glm::dvec3 origin);
// A node's quantization frame from its directory entry.
NodeFrame node_frame(const store::NodeEntry& e);

// The meshlet bounds of a decoded node into `out`: 6 floats per meshlet (min x, y, z, max x, y, z;
// relative to scene.origin, grown by each particle's radius, as render::append_node computes
// them). Reads its arguments only, so any thread may run it: the cache runs it on its reader
// threads (IoOptions::prepare), off the render loop. Errc::format for a meshlet that overruns
// the node's particles, a type index outside the type table or missing per-particle radii.
Status meshlet_bounds(const PoolScene& scene, uint32_t node, const NodeFrame& frame, const store::NodeData& data,
                      std::vector<float>& out);
// A decoded node's particle records in the pool's layout into `out`: 4 uint16 per particle (x,
// y, z quantized in the node's frame, type index), the bytes NodePool::upload stages. Any
// thread may run it (the cache's reader threads). Precondition: data.qpos holds 3 per particle.
void pack_particles(const store::NodeData& data, std::vector<uint16_t>& out);

// Merges each region into the one before it where both its source and its destination continue
// that region's (order kept; regions of one vkCmdCopyBuffer never overlap, so neither do merged ones).
void coalesce_copies(std::vector<VkBufferCopy>& regions);

class NodePool {
 public:
  // Pages = min(budget / page_bytes, store_pages), where store_pages would hold every node at
  // once (a larger pool is never used), further limited so that each pool buffer stays within
  // maxStorageBufferRange (lavapipe's 128 MiB: 16 M particle slots of 8 B). The renderer's
  // per-sprite scratch does not bound it (draw lists are drawn in chunks). staging_bytes:
  // per-frame upload area (also bounds a frame's uploads).
  static Result<std::unique_ptr<NodePool>> create(vk::Context& ctx, const PoolLayout& layout, PoolScene scene,
                                                  uint32_t node_count, uint64_t budget_bytes, uint64_t store_pages,
                                                  uint64_t staging_bytes);
  ~NodePool();
  NodePool(const NodePool&) = delete;
  NodePool& operator=(const NodePool&) = delete;

  const PoolLayout& layout() const { return layout_; }
  uint32_t page_count() const { return pages_; }
  uint32_t free_pages() const { return uint32_t(free_.size()); }
  uint32_t meshlet_slots() const { return pages_ * layout_.page_meshlets; }
  uint64_t particle_slots() const { return uint64_t(pages_) * layout_.page_particles; }
  const mds::streaming::DeviceBudget& budget() const { return budget_; }
  // The device's buffer ranges left fewer pages than the budget pays for and the store could
  // use: the cache has less room than it was given.
  bool device_capped() const { return device_capped_; }
  bool resident(uint32_t node) const { return !node_pages_[node].empty(); }
  uint64_t staging_free() const { return staging_.size() - staging_head_; }

  VkBuffer particles() const { return particles_.get(); }
  VkBuffer radii() const { return radii_.get(); }
  VkBuffer property() const { return property_.get(); }
  VkBuffer color() const { return color_.get(); }
  VkBuffer meshlets() const { return meshlets_.get(); }
  VkBuffer meshlet_class() const { return classes_.get(); }

  // Starts a frame's transfers (resets the staging area). Precondition: the previous frame's
  // command buffer has completed.
  void begin_frame();
  // Frees node's pages and empties its meshlet slots (particle_count = 0).
  Status evict(VkCommandBuffer cmd, uint32_t node);
  // Staging bytes an upload of `data` takes.
  uint64_t upload_bytes(const store::NodeData& data) const;
  // Places a decoded node: takes pages_for(n, m) free pages, converts it into GPU records in the
  // staging area and gathers the copies and the reset of its meshlet slots' classes to P (recorded
  // by end_frame, or by an eviction of one of its pages in this frame). `bounds`: the
  // node's meshlet_bounds when the caller has them (6 per meshlet), else empty and computed here;
  // `particles`: its pack_particles records (4 per particle), else empty and packed here.
  // Errc::budget when pages or staging space are short (nothing changes then); Errc::format when
  // the node's data is inconsistent (nothing changes either).
  Status upload(uint32_t node, const NodeFrame& frame, const store::NodeData& data, std::span<const float> bounds = {},
                std::span<const uint16_t> particles = {});
  const PoolScene& scene() const { return scene_; }
  // Records this frame's gathered transfers and makes them visible to the shaders (after the
  // last upload/evict).
  void end_frame(VkCommandBuffer cmd);
  // Copy regions recorded since the last call (after merging): a GPU may pay per region, so
  // the stress report gives them per frame (per_frame.upload_regions).
  uint32_t take_copy_regions();

 private:
  NodePool() = default;

  vk::Context* ctx_ = nullptr;
  PoolLayout layout_;
  PoolScene scene_;
  uint32_t pages_ = 0;
  std::vector<uint32_t> free_;                      // free page indices (stack)
  std::vector<std::vector<uint32_t>> node_pages_;   // pages of each resident node
  mds::streaming::DeviceBudget budget_{0};
  vk::Buffer particles_, radii_, property_, color_, meshlets_, classes_, staging_buf_;
  std::span<std::byte> staging_;
  uint64_t staging_head_ = 0;
  // Records the gathered regions: zeros (evictions) first, then, after a barrier, the uploads'
  // copies; a barrier first when a flush of this frame came before.
  void flush(VkCommandBuffer cmd);

  bool transfers_ = false;  // transfers gathered or recorded since begin_frame
  bool flushed_ = false;    // flush() recorded copies this frame
  vk::Buffer zeros_;        // kZeroPages x page_meshlets GpuMeshlet records of zero bytes (also P = 0 classes)
  uint32_t copy_regions_ = 0;  // take_copy_regions()
  std::vector<VkBufferCopy> zero_meshlets_, zero_classes_;  // from zeros_
  std::vector<VkBufferCopy> copy_particles_, copy_radii_, copy_property_, copy_color_, copy_meshlets_;  // from the staging area
  std::vector<uint8_t> page_pending_;  // page has an upload region not yet flushed
  std::vector<uint32_t> pending_pages_;  // those pages (cleared by flush)
  bool device_capped_ = false;
};

}  // namespace mds::render::streaming_gpu
