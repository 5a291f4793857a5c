// The GPU cache of out-of-core rendering (issue 4), driven by occlusion class: Ibrahim et al. §8
// (future work: data larger than GPU memory, a GPU-resident cache following the occlusion
// classes) and Grottel et al. §3.1/§3.3 (the previous view's visible data are the first
// occluders; a fixed upload budget per frame; front-to-back loading).
// Per frame (StreamCache::update, on the render thread, recorded into the frame's command buffer):
//   1. node classes of the last culling iteration (every node of the store, resident or not:
//      the node directory stays on the GPU) -> streaming::ResidencyTable;
//   2. demand: the nodes the frame needs (in the frustum, not O), marked in use (kept by step 3);
//   3. finished reads (streaming::IoPool: pread + XXH3 check + lz4 decode on background threads)
//      are placed into the paged pool (NodePool), evicting by the policy's order (occlusion: O,
//      then M, then L/P, each outside the view first, then by least recent use and distance;
//      never a node drawn this frame), at most upload_bytes_per_frame per frame; a read that is
//      no longer wanted is dropped, unless it was found occluded in the frustum and room can be
//      made from nodes evicted before it (keep_late_arrivals);
//   4. prefetch: requests in the policy's order (occlusion: P, then L, then M, front to back),
//      a window of reads at a time (streaming::ReadWindow), like TCP's congestion window: at rest (a held view) it starts
//      at 4, grows by 4 after 3 frames whose arrivals were
//      all still wanted and is halved when a read arrives for a node found occluded meanwhile
//      (additive increase, multiplicative decrease), so that the culling loop classifies what lies
//      behind the first arrivals before it is read: a node classified O before it was ever loaded
//      is never read. While the camera moves (every frame a new view whose classes never mature)
//      the window opens to max_outstanding when the motion starts and keeps its state across the
//      views (halved by waste, doubled by a calm frame); a read of a node that merely left the
//      frustum is not counted as waste. Queued reads of nodes that became unwanted are cancelled.
//      At rest (occlusion policy, StreamSettings::wave_settle_frames > 0) the reads go out in
//      waves: no new read while a read is in flight or a wanted node was placed fewer than
//      wave_settle_frames frames ago, so every wave is chosen from classes that already saw the
//      previous one; a node of a wave that turns O within those frames counts as waste.
//      A series step (StreamSettings::prior): the first wave at rest is every node matching, by
//      box overlap, a node the view of the frame before wanted (docs/streaming.md, "Series steps").
//   5. hits / misses of the frame's demand, counted after step 3 (the frame draws after it).
// The render loop never waits on disk: update() only polls.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "core/result.h"
#include "render/camera.h"
#include "render/renderer.h"
#include "render/streaming/node_pool.h"
#include "store/store_reader.h"
#include "streaming/io_pool.h"
#include "streaming/node_match.h"
#include "streaming/read_window.h"
#include "streaming/residency.h"
#include "vk/context.h"

namespace mds::render::streaming_gpu {

struct CacheFrame {
  uint32_t nodes_uploaded = 0;
  uint64_t bytes_uploaded = 0;
  uint32_t hits = 0, misses = 0;
  uint32_t reads_requested = 0;  // node reads submitted by this frame's prefetch (step 4)
  uint32_t copy_regions = 0;     // the pool's copy regions recorded this frame (NodePool::take_copy_regions)
  bool upload_stall = false;
  bool exhausted = false;      // wanted nodes do not fit the pool
  bool complete = false;       // every wanted node resident (or failed / beyond the budget), nothing in flight
  std::vector<uint32_t> wanted;  // demand of this frame (StreamSettings::record_trace)
  std::vector<uint8_t> wanted_resident;  // parallel to wanted: 1 = resident for this frame (a hit)
  // Nodes read this frame of which the slices or the threshold kept nothing: directory() now has their
  // kGpuNodeLeftOut flag, which the caller copies to the device's node directory.
  std::vector<uint32_t> left_out;
};

class StreamCache {
 public:
  // `reader` must outlive the cache. Errc::budget when the budget cannot hold the largest node.
  static Result<std::unique_ptr<StreamCache>> create(vk::Context& ctx, const store::StoreReader& reader,
                                                     const StreamSettings& settings, const glm::dvec3& origin);
  ~StreamCache();
  StreamCache(const StreamCache&) = delete;
  StreamCache& operator=(const StreamCache&) = delete;

  NodePool& pool() { return *pool_; }
  // The node directory (GpuNode per store node: frame, bounds, counts), uploaded once by the renderer.
  const std::vector<gpu::GpuNode>& directory() const { return directory_; }
  // Per-node voxel lists of the density updates (CSR over nodes, CullScene::node_density). With
  // slices or a threshold, the counts of what each node keeps (estimated for a node they cut: its
  // count in a voxel times the share of the voxel's part of the node box that the slices keep,
  // times the share of its particles its property histogram says the threshold keeps).
  const std::vector<uint32_t>& voxel_first() const { return voxel_first_; }
  const std::vector<glm::uvec2>& voxel_refs() const { return voxel_refs_; }
  uint32_t max_meshlet_particles() const { return max_meshlet_; }
  // With slices or a threshold, the counts of `v` (the store's grid) replaced by the sums of
  // voxel_refs(), so that the volume and the nodes' subtractions agree; without, v unchanged.
  void kept_density(culling::DensityVolume& v) const;
  uint64_t live_meshlets() const { return live_meshlets_; }
  // The pool still fills: its free room holds the store's largest node (it has not filled up).
  bool filling() const;
  // The pages of the nodes the last update() counted as wanted (in the frustum, not O;
  // CacheStats::wanted_bytes) fit the pool. Before its first classification a view wants every
  // node of its frustum that no earlier view found O (a cold cache's view: all of them).
  bool holds_wanted() const;
  std::vector<uint64_t> node_device_bytes() const { return node_bytes_; }
  // node_device_bytes() with every node the slices or the threshold cut at the pages of what it keeps (0 when
  // nothing): the cut nodes not read yet are read and thinned here, synchronously (StoreReader's
  // reads are positioned, safe beside the reader threads). For offline simulations that replay
  // the demand at the sizes the nodes would have had (stress); not counted in the stats.
  Result<std::vector<uint64_t>> node_device_bytes_kept() const;

  // New view: frustum, distances and projected sizes of every node. The culling loop restarts
  // its classes (paper 000 Sect. 5.1), the cache keeps its own (Grottel et al.'s O_{t-1}: what
  // was visible in the previous view is wanted first, what was occluded stays unread): a node
  // leaving the frustum becomes O, a node entering it P, the others keep their class.
  // While the camera moves, every node learns in how many of the next kLookaheadFrames views,
  // extrapolated linearly from the last two (eye and target), it lies (ResidencyTable::set_ahead):
  // nodes that stay in view are fetched first and evicted last, and nodes outside the frustum
  // that the motion brings in are read after every wanted node, into spare room (residency.h).
  // `next`: the camera's next views when the caller knows them (a camera path replay, at most
  // kLookaheadFrames are used, near/far fitted). When one of them differs from `camera` the view
  // is moving from its first frame (the read window opens at once, ReadWindow::new_view) and the
  // look-ahead takes these views instead of the extrapolation; when all equal `camera` the path
  // holds it. Empty: unknown (a viewer under a user's hand), the rules above.
  void set_view(const Camera& camera, double aspect, std::span<const Camera> next = {});
  static constexpr int kLookaheadFrames = 3;
  // A node is dense when its spheres fill at least this share of its culling box (a bound from
  // the directory: count x the volume of a sphere of max_radius / box volume). Dense-block nodes
  // of the synth scenes fill 0.2-0.6, the ablation plume's gas nodes less (front_node_alone).
  static constexpr double kDenseNodePacking = 0.1;
  // Node classes of a culling iteration (MDS_CULL_CLASS_*, one per node). `mature`: the view
  // has run enough iterations for its classes to replace the cache's; before that only new O
  // (confident occlusion) and upward moves are taken, so a camera in motion, whose views never
  // mature, keeps the classes of the last view that did, and does not re-read what it knew
  // occluded. An O expires, though: a node whose O no iteration has confirmed for more than
  // StreamSettings::occluded_hold_frames frames takes the iteration's class. Its occluders have left the view
  // (a fly-through passes them) or are no longer resident; kept for good, the nodes behind a
  // fly-through's first layer stayed O after the camera had passed it, nothing was wanted or
  // drawn for the rest of the path (porous 1M: from frame 19 of 48), and the demand trace, so
  // the hit rates and the Belady bound, described an empty view.
  void set_classes(std::span<const uint32_t> classes, bool mature);
  // Every node's world box and whether the current view wants it (demanded: in the frustum, not
  // O), for the cache of the next store of a series (StreamSettings::prior).
  mds::streaming::PriorView prior_view() const;
  // A node of this store matches a node of the prior view when their boxes' IoU is at least this
  // (match_boxes). Porous / ablation series of 1000-particle nodes: docs/streaming.md "Series steps".
  static constexpr double kPriorMinIou = 0.5;
  // One frame (see the file comment); transfers are recorded into cmd.
  Result<CacheFrame> update(VkCommandBuffer cmd, uint64_t frame);
  CacheStats stats() const;
  // Every node: its requests and reads, its first request's frame, carried, residency and class (NodeLogEntry).
  std::vector<NodeLogEntry> node_log() const;

 private:
  StreamCache() = default;
  bool demanded(uint32_t node) const;
  Status evict_for(VkCommandBuffer cmd, uint32_t incoming, uint64_t frame, bool& stalled);
  // Whether a finished read of node i, no longer fetchable (found O meanwhile), is placed anyway
  // (StreamSettings::keep_late_arrivals): in the frustum, within the frame's upload and staging
  // budgets, and the room it needs comes from nodes evicted before it (evicted_before).
  bool keep_late_arrival(uint32_t i, const store::NodeData& data, uint64_t uploaded, uint64_t frame) const;

  const store::StoreReader* reader_ = nullptr;
  StreamSettings settings_;
  // StreamSettings::prior: per node, 1 = it matches a node the view before wanted; the first wave
  // at rest is these nodes, all at once (carried_wave_ until it went out).
  std::vector<uint8_t> carried_;
  bool carried_wave_ = false;
  std::unique_ptr<NodePool> pool_;
  std::unique_ptr<mds::streaming::IoPool> io_;
  std::unique_ptr<mds::streaming::ResidencyTable> table_;
  std::vector<gpu::GpuNode> directory_;
  std::vector<uint8_t> dense_;  // per node: its spheres fill >= kDenseNodePacking of its box (waves)
  // Per node: the share of its particles StreamSettings::threshold keeps, from its property
  // histogram (1 without one): a wave's coverage and dense_ count a thinned node at that share.
  std::vector<float> thinned_;
  // Per node, what StreamSettings::slices and ::threshold do to it (store::SliceCover; `all`
  // without them); set by create() and only read after (the reader threads filter by it).
  std::vector<uint8_t> cover_;
  // Per node: the filters left it out (cover_ none, or no particle kept when it was read); set on
  // the render thread. Such a node is outside every view.
  std::vector<uint8_t> left_out_;
  std::vector<uint8_t> measured_;  // per node: node_bytes_ is what the filters keep of it (read once)
  // With StreamSettings::threshold: store::threshold_table (kQuantMax + 1 entries); else empty.
  std::vector<uint8_t> property_kept_;
  // The in-memory filter (render/scene.h) of a node the slices or the threshold cut.
  ParticleFilter filter(uint32_t node) const;
  std::vector<NodeFrame> frames_;
  std::vector<uint64_t> node_bytes_;
  std::vector<uint32_t> voxel_first_;
  std::vector<glm::uvec2> voxel_refs_;
  uint32_t max_meshlet_ = 0;
  uint64_t live_meshlets_ = 0;  // meshlets of resident nodes
  uint64_t largest_node_bytes_ = 0;  // the store's largest node in the pool (pages)
  std::vector<uint32_t> node_meshlets_;
  std::unordered_map<uint32_t, mds::streaming::IoCompletion> ready_;  // read, not yet placed
  std::vector<uint32_t> requested_;                                   // queued, in flight or ready
  CacheStats stats_;
  bool exhausted_ = false;
  bool has_view_ = false;
  Camera last_camera_;  // of the previous set_view (look-ahead extrapolation)
  double aspect_ = 1.0;  // width / height of the view (screen_share of the wave coverage)
  std::vector<uint64_t> placed_frame_;  // frame of each node's last placement (waves at rest)
  std::vector<uint32_t> requests_;      // per node: read requests submitted (node_log)
  std::vector<uint32_t> reads_;         // per node: reads finished, bytes_read counted (node_log)
  std::vector<int64_t> first_request_;  // per node: frame of its first request, -1 none (node_log)
  std::vector<uint8_t> placed_late_;    // that placement kept a late arrival (keep_late_arrival)
  std::vector<uint64_t> o_confirmed_;   // frame a culling iteration last classified the node O
  uint64_t frame_ = 0;                  // the frame of the last update()
  mds::streaming::ReadWindow window_;  // reads queued or in flight at a time (step 4)
  // Step 4's plan is kept while nothing it depends on changed: a plan that requested nothing
  // (no room for the first node in the order, or nothing to fetch) is not made again until a
  // view, a class, a read or a placement changes. A converged view whose wanted nodes exceed the
  // pool otherwise sorted every wanted node each frame (ablation close-up at 8M particles:
  // 5000 wanted nodes, ~0.7 ms of CPU per converged frame).
  bool plan_stale_ = true;
  bool plan_idle_ = false;       // the last plan requested nothing
  bool plan_exhausted_ = false;  // ... because the pool had no room for its first node
};

}  // namespace mds::render::streaming_gpu
