// The sphere-glyph renderer with progressive super-sampling and probabilistic occlusion culling
// (paper 000, Sect. 3.5). render() submits one frame per super-sample (--spp); a frame is:
//   0. while culling is active (RenderSettings::cull, not yet converged): one culling iteration
//      of culling::CullLoop (samples_per_iteration occlusion sampling passes, pyramid,
//      classification, density histogram update; see cull_loop.h);
//   1. "draw_list": a compute pass writes the draw list (DrawListHeader + meshlet ids): every
//      meshlet (draw_list_all.comp, --no-cull) or the potentially visible set (every meshlet not
//      in class O, CullLoop::record_draw_list);
//   2. "prepass": compute sprite pre-pass over the listed meshlets' particles (one GpuSprite
//      each, tangent-plane bounds); small sprites are rasterized by compute into a visibility
//      buffer (one 64-bit atomicMin per pixel, sprite_raster.h), the others get indirect draw
//      commands;
//   3. "draw": the other sprites as point sprites (largePoints, default where the point size
//      range allows) or quads: ray-cast spheres with exact depth, with a Halton(2,3) sub-pixel
//      jitter in the projection, into the visibility buffer (visibility route) or into colour +
//      depth attachments (attachment route; renderer_impl.h);
//   4. "resolve" (visibility route: each pixel's nearest sphere shaded once) or "accumulate"
//      (attachment route): the frame's colour (a = coverage) added into a float32 image.
// The written image is accumulation / spp. When culling has not converged after spp frames,
// culling iterations continue alone (no drawing) until convergence or max_iterations. The image
// then holds frames drawn with the classes of unsettled iterations; with
// RenderSettings::converged_image the spp frames are drawn again with the final classes.
// GPU timestamps are recorded per pass.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "core/cell.h"
#include "core/result.h"
#include "render/camera.h"
#include "render/colormap.h"
#include "render/frame_pacer.h"
#include "render/culling/cull_loop.h"
#include "render/culling/density_volume.h"
#include "render/mesh_sprites.h"
#include "render/scene.h"
#include "store/slice.h"
#include "store/store_reader.h"
#include "store/threshold.h"
#include "streaming/io_pool.h"
#include "streaming/node_match.h"
#include "streaming/residency.h"
#include "vk/context.h"

namespace mds::render {

// Out-of-core rendering (issue 4): the particle payload of a store streamed through a GPU cache of
// fixed size (src/render/streaming/). Used by Renderer::create_streaming.
struct StreamSettings {
  uint64_t gpu_budget = 0;  // bytes of the payload pool (--gpu-budget); must hold the largest node
  // --slice (store/slice.h): nodes whose every centre the slices cut are never wanted nor read;
  // the others lose the cut particles on the reader thread that decodes them; the density volume
  // and the nodes' voxel lists count what is kept (docs/streaming.md, "Slices").
  std::vector<store::Slice> slices;
  // --threshold (store/threshold.h): from each node's property histogram (store kFlagPropertyHistogram),
  // nodes with no value it keeps are never read, nodes it cuts are thinned on the reader thread,
  // and their voxel counts scaled by the share it keeps (docs/streaming.md, "Thresholds").
  std::optional<store::Threshold> threshold;
  // The pool holds the store's per-particle colours (store kFlagColor), 2 KiB a page more:
  // Renderer::create_streaming sets it where they are drawn (--color-by color).
  bool colors = false;
  streaming::Policy policy = streaming::Policy::occlusion;  // --policy occlusion|lru|fifo
  streaming::IoOptions io;                                   // reader threads, simulated latency/bandwidth
  uint64_t upload_bytes_per_frame = 32ull << 20;  // transfer budget per frame (Grottel et al. 3.3)
  // Reads queued or in flight at a time: a window that starts at 4 per view, grows by 4 after 3
  // frames whose finished reads were all still wanted and halves when reads arrived for nodes the
  // culling loop had meanwhile found occluded (reading ahead of the classification wastes I/O;
  // too few reads slow convergence). This is its cap, and the window a moving camera opens to:
  // 128 reads fill a pool of 128 nodes at once (the benchmark's 1/8-store pool holds ~70 nodes
  // of 1000 particles, ~11.5 KiB each on the device; 64 left its first moving frame short of it).
  uint32_t max_outstanding = 128;
  // While the camera moves the window halves only after a frame in which at least this share of
  // the arrived reads were for nodes found occluded meanwhile (streaming::ReadWindowSettings):
  // with any waste halving it, the noisy classes of moving frames collapsed the window to 2-4
  // reads per frame on some runs of the porous dynamic-resolution fly-through, while 70-90
  // wanted nodes were missing (docs/streaming.md, "Read window while moving"). 0: any waste.
  double moving_waste_share = 0.5;
  // Before a view matures (every view while the camera moves), a node the culling loop
  // classified O stays O in the cache until no iteration has confirmed it for this many frames (StreamCache::set_classes): one iteration of
  // a moving view is noisy (a node flips between O and P from frame to frame), and a node known
  // occluded should not be read for one such flip; but an O kept for good outlives its
  // occluders (a fly-through passes them, and the view behind was never read). Measured on the
  // porous fly-through, docs/streaming.md "Camera changes".
  uint32_t occluded_hold_frames = 1;
  // Reads in waves at rest (occlusion policy): the window's reads go out, then none until all of
  // them are placed and have been resident for this many frames, so that the culling loop has
  // sampled them as occluders and classified what lies behind before the next wave is chosen
  // (a node found O meanwhile is never read; the window starts at wave_nodes nodes, grows by
  // wave_nodes while no wave brings a node that turns O, halves when one does, not below
  // wave_nodes). 0: no waves (the window only).
  uint32_t wave_settle_frames = 2;
  // Nodes of the first wave of a held view, and the window's additive step at rest. Smaller
  // waves read fewer nodes before the nodes in front of them are sampled, in more frames
  // (docs/streaming.md, "Wave size": without front_node_alone, 1 reads 0.89x the bytes of 2 on
  // four close-ups, in 1.3x the frames; wide views read the same bytes in 1.3-1.4x the frames).
  uint32_t wave_nodes = 2;
  // A wave at rest also takes, front to back, the nodes whose bounding spheres cover this many
  // images (streaming::screen_share summed; at least the window's nodes, at most
  // max_outstanding): one layer of occluders over the whole image, sampled before what lies
  // behind it is chosen. A wide view's front is dozens of small nodes, which waves of
  // wave_nodes read a few at a time over many frames (docs/streaming.md, "Wave coverage"). 0:
  // the window alone.
  double wave_coverage = 1.0;
  // At rest, a wave whose first node is large on screen (bounding-sphere radius >= a quarter of
  // the image height) and dense (its spheres fill >= 10 % of its box) holds that node alone: it
  // may hide most of what the window would read with it (docs/streaming.md, "Wave size").
  bool front_node_alone = true;
  // A read that arrives for a node found occluded meanwhile (in the frustum, class O) is placed
  // when the room it needs can be made from nodes that come before it in the eviction order
  // (nodes outside the view, or used longer ago), instead of being dropped: its bytes are read,
  // and on a fly-through what a gap showed for one frame is often seen again a few frames later
  // (docs/streaming.md, "Late arrivals"). It never evicts a node drawn this frame.
  bool keep_late_arrivals = true;
  bool record_trace = false;  // FrameReport::wanted filled (stress: offline Belady bound)
  // A store replaced by the next frame of a series (or a streaming renderer made again): the view
  // before, whose wanted nodes, matched to this store's nodes by box overlap
  // (streaming/node_match.h), are the first wave at rest -- all of them at once, front to back --
  // instead of a cold cache's waves from the front (docs/streaming.md, "Series steps"). Null: a
  // cold start. Set by the caller from Renderer::prior_view() when carry_view is on.
  std::shared_ptr<const streaming::PriorView> prior;
  bool carry_view = true;  // --series-first-wave prior|cold: whether callers pass `prior`
};

struct RenderSettings {
  uint32_t width = 1920;
  uint32_t height = 1080;
  uint32_t spp = 64;
  glm::vec3 background_srgb{0.12f, 0.12f, 0.13f};  // default: dark grey
  // Colour per type index (sRGB), replacing the palette's (store::type_colors resolves a
  // user's --type-color against the store's types); shorter or empty: the rest keep the palette.
  std::vector<glm::vec3> type_colors_srgb;
  // Colour by coordinate or property instead (--color-by, --colormap, render/colormap.h) along a world axis
  // over [lo, hi]; lo == hi: the scene's bounds along the axis (Renderer::color_range).
  ColorBy color_by;
  bool cull = false;                                 // probabilistic occlusion culling (false: --no-cull)
  culling::CullSettings cull_settings;               // used when cull is set
  std::shared_ptr<const culling::DensityVolume> density;  // from the store; null: built from the scene
  // In memory: the culling loop's scene (culling::cull_scene of the scene and `density`), made
  // beforehand -- the viewer makes it on the thread that preloads a series' next frame (80-90 ms
  // of a 1M step). Precondition: made from this scene and this density volume; null: made by
  // create. Unused when streaming.
  std::shared_ptr<const culling::CullScene> cull_scene;
  MeshShaderMode mesh_shaders = MeshShaderMode::automatic;  // sprite path (render/mesh_sprites.h)
  // Visibility route (one uint64 of depth and sprite index per pixel, each pixel shaded once)
  // where the device has 64-bit buffer atomics, on either sprite path; false: colour + depth
  // attachments (the route of devices without those atomics).
  bool visibility_route = true;
  // Accumulate into a storage buffer where 16 bytes per pixel fit maxStorageBufferRange; false:
  // always into an rgba32f storage image (the fallback for larger images). Same image either way.
  bool accumulation_buffer = true;
  // Visibility route: the resolve shades the covered pixels listed by a compaction pass (where
  // the device has subgroup ballots in compute); false: one resolve thread per pixel of the
  // viewport. Same image either way; on lavapipe the list is cheaper (docs/rendering.md).
  bool covered_pixel_list = true;
  // ... but only while the view's first frame found fewer than this share of the pixels covered
  // (break-even on lavapipe at 1920x1080: about half; 1: always the list).
  double covered_list_max_coverage = 0.5;
  // After a converged culled in-memory render() (not with a GPU budget): this many frames of the potentially visible set and as
  // many of every meshlet, alternately, with weight 0 (the image is unchanged); CullStats
  // frame_ms_paired_*. 0: none. On a shared machine a ratio of two separate renders' medians
  // carries both renders' noise; the paired frames see the same load.
  uint32_t paired_frames = 0;
  // In-memory render() with culling: once the loop has converged, draw the spp frames again with
  // the final potentially visible set (the accumulation restarted), so that the image is the one
  // the viewer shows after convergence, not an average over frames drawn while the classes were
  // still changing (mdstream bench; docs/rendering.md, "What accuracy costs in time").
  bool converged_image = false;
  // After convergence, each particle of the potentially visible set is tested against the final
  // confidence pyramid with the meshlet rule (Sect. 5) and not drawn when it is class O on its
  // own (shaders/include/particle_occlusion.h). Off by default (every particle of the set is
  // drawn, the paper's behaviour): with the paper's expected sample area the per-pixel confidence
  // overstates coverage where particles are about a pixel wide, and the test then drops visible
  // particles (5.9-10.4 % of the pixels beyond 0.1 on 1M views at 16 spp); with
  // exact coverage (CullSettings::coverage) it loses <= 0.6 %, with automatic up to 4 %
  // (docs/rendering.md). The CLI's --particle-occlusion auto turns it on with --coverage exact.
  // Paced occlusion sampling at rest (Renderer::step): an iteration of a view whose sampling
  // pass costs more than the recent views' median runs fewer passes (render/sample_pacer.h);
  // convergence still needs converge_iterations x samples_per_iteration quiet passes.
  bool pace_sampling = true;
  bool particle_occlusion = false;
  // Screen-space ambient occlusion (shading/ambient_occlusion.h, SAO): the world radius of the
  // taps (> 0) and the strength sigma; 0 strength: off. The visibility route only (the attachment
  // route draws without it; RenderStats::ambient_occlusion says which). The CLI resolves --ao
  // auto and the default radius (cli/vulkan/render_options.cpp).
  double ao_radius = 0.0;
  double ao_strength = 0.0;
  // The simulation cell's edges (render/cell_lines.h; docs/rendering.md, "Simulation cell"), in
  // world coordinates: lines of cell_width_px pixels in cell_color_srgb, depth tested against the
  // spheres; they occlude no particle for the culling. None: not drawn (the CLI resolves --cell).
  std::optional<SimulationCell> cell;
  glm::vec3 cell_color_srgb{0.75f, 0.75f, 0.75f};
  float cell_width_px = 1.5f;
  // Sprite records the compute sprite path holds at once (48 B each, bound whole, so at most
  // maxStorageBufferRange / 48: 2.8 M on lavapipe). A draw list with more particles is turned
  // into sprites and drawn in chunks of capacity / max meshlet size entries, so neither the
  // in-memory scene nor the streaming pool is bounded by it (gpu_types.h SpriteDrawHeader,
  // "Chunks"; docs/rendering.md). 0: the device's bound or one per particle a full draw list can
  // hold (meshlet slots x max meshlet size), whichever is less. Smaller values force chunks (tests).
  uint64_t sprite_capacity = 0;
};

// Culling loop statistics of one render() (RenderStats::cull).
struct CullStats {
  bool enabled = false;
  bool converged = false;               // Sect. 5.3 criterion met (false: max_iterations reached)
  uint32_t iterations = 0;              // culling iterations run
  uint32_t iterations_after_spp = 0;    // of those, run without drawing after the spp frames
  uint32_t samples = 0;                 // occlusion sampling passes run (iterations * per iteration)
  uint32_t samples_per_iteration = 0;
  uint32_t iterations_to_converge = 0;  // 0 when not converged
  uint32_t samples_to_converge = 0;     // sampling passes until convergence (paper Table 4 "smp")
  uint32_t bins = 0;                    // density histogram bins per pixel
  // Occlusion sampling passes run in compute / rasterized (the loop's lifetime;
  // CullSettings::sample_route, docs/rendering.md).
  uint32_t sample_passes_compute = 0, sample_passes_raster = 0;
  double sample_ms_compute = -1.0, sample_ms_raster = -1.0;  // last comparison, ms per pass (-1: none)
  bool shared_box_tests = false;        // box tests shared by subgroups (cull_classify_coop.comp)
  bool node_per_subgroup = false;       // a subgroup per node in the node classification (mode 2)
  bool shared_cells = false;            // a shared test's occupied cells one at a time, texels shared (kSharedCells)
  uint32_t budget = 0;                  // occluder meshlets per sampling pass
  uint64_t meshlets_culled = 0;         // meshlets in O after the last classification
  std::vector<uint32_t> class_counts;   // P, L, M, O after the last classification
  std::vector<uint32_t> node_class_counts;  // nodes P, L, M, O then (without the nodes --slice leaves out)
  std::vector<uint32_t> changed_per_iteration;
  std::vector<uint32_t> culled_per_iteration;
  // Streaming (Renderer::step): per iteration of the view, its passes' occluder budget
  // (CullLoop::pass_budget) and the occluders its last pass selected (CullCounters::selected).
  std::vector<uint32_t> budget_per_iteration;
  std::vector<uint32_t> selected_per_iteration;
  double time_to_converge_ms = 0.0;     // wall time from render() start
  // GPU ms per frame (sum of its timestamped passes), medians: frames with a culling iteration;
  // frames after convergence (including the timing frames after a convergence past spp, which
  // run every pass of a sampling frame but accumulate with weight 0, or the frames drawn again
  // for RenderSettings::converged_image); culling iterations without drawing.
  double frame_ms_during_culling = 0.0;
  double frame_ms_after_convergence = 0.0;
  std::map<std::string, double> pass_ms_after_convergence;  // per pass, median over those frames
  double iteration_ms_without_draw = 0.0;
  // Paired frames (RenderSettings::paired_frames): medians of the potentially-visible-set frames
  // and of the every-meshlet frames run alternately after convergence; their ratio is the
  // speed-up measured in one process and the same minutes.
  uint32_t paired_frames = 0;
  double frame_ms_paired_culled = 0.0;
  double frame_ms_paired_all = 0.0;
  // The last frame after convergence (RenderSettings::particle_occlusion): particles of the
  // potentially visible set, and of those the ones the particle occlusion test hid.
  uint64_t particles_listed = 0;
  uint64_t particles_occluded = 0;
};

// Linear RGBA, row-major from the top-left; rgb already averaged over spp and composited over
// the background, a = average coverage.
struct FrameImage {
  uint32_t width = 0, height = 0;
  std::vector<float> rgba;
  glm::vec4 at(uint32_t x, uint32_t y) const {
    const float* p = &rgba[4 * (size_t(y) * width + x)];
    return {p[0], p[1], p[2], p[3]};
  }
};

// Streaming cache counters (cumulative since the renderer was created).
struct CacheStats {
  bool enabled = false;
  uint64_t gpu_budget_bytes = 0;  // --gpu-budget
  uint64_t pool_bytes = 0;        // payload pool actually allocated (<= budget)
  uint64_t gpu_peak_bytes = 0;    // peak payload bytes reserved in the pool
  uint64_t resident_bytes = 0;
  uint64_t scratch_bytes = 0;     // per-frame working buffers sized by the pool (sprites), not payload
  uint64_t store_payload_bytes = 0;  // compressed node payload bytes of the whole store
  uint64_t bytes_read = 0;        // compressed bytes read from the store
  uint64_t bytes_uploaded = 0;    // bytes copied to the device pool
  uint64_t nodes = 0;
  uint64_t nodes_resident = 0;
  uint64_t nodes_loaded = 0;      // uploads (a node evicted and loaded again counts twice)
  uint64_t nodes_never_loaded = 0;
  uint64_t nodes_failed = 0;      // corrupted/unreadable, reported once and skipped
  uint64_t nodes_left_out = 0;  // left out by --slice or --threshold: nothing kept (never read), or none kept when read
  uint64_t cache_hits = 0;        // per frame, per wanted node (not O, in the frustum): resident
  uint64_t cache_misses = 0;      //   ... not resident
  uint64_t evictions[4] = {};     // by class at eviction: P, L, M, O
  uint64_t upload_stalls = 0;     // frames where a ready node could not be placed (pool full of needed nodes)
  uint64_t late_arrivals_kept = 0;  // reads found occluded on arrival and placed anyway (keep_late_arrivals)
  uint64_t in_flight = 0;         // reads queued or running now
  bool budget_exhausted = false;  // the last frame wanted more nodes than fit (image incomplete)
  bool pool_device_capped = false;  // the device's limits made the pool smaller than the budget
  uint64_t wanted_nodes = 0;      // the last frame's demand: nodes in the frustum and not in class O
  uint64_t wanted_bytes = 0;      //   ... and the pool pages they take (bytes), resident or not
  // StreamSettings::prior: the nodes the view before wanted, and this store's nodes matched to one
  // of them (the carried first wave); 0 without a prior view.
  uint64_t prior_wanted_nodes = 0;
  uint64_t carried_nodes = 0;
  // The current view's first frame with every wanted node resident and nothing in flight
  // (FrameReport::complete), counted from its first frame (1 = that frame), and the wall time
  // from set_view to the end of that frame; 0 / -1 before.
  uint32_t frames_to_complete = 0;
  double ms_to_complete = -1.0;
  std::vector<std::string> errors;  // one message per failed node
};

// One node as the streaming cache saw it in the current view (Renderer::node_log; render
// --node-log): which nodes it read and when, and how their classes ended.
struct NodeLogEntry {
  uint32_t requests = 0;             // read requests submitted, cancelled ones too (read again after an eviction: 2)
  uint32_t reads = 0;                // reads finished (their bytes are in bytes_read), failed ones too
  int64_t first_request_frame = -1;  // the renderer's frame index of its first request (0: its first frame); -1: never
  bool carried = false;              // in a series step's carried first wave (StreamSettings::prior)
  bool loaded = false;               // placed in the pool at least once
  bool resident = false;             // in the pool now
  bool in_frustum = false;           // of the current view
  bool wanted = false;               // demanded by the last frame: in the frustum, not O, readable
  uint8_t cls = 0;                   // the cache's class of it (MDS_CULL_CLASS_*)
};

// One frame of the progressive API (Renderer::step).
// GPU time of one frame: its timestamped passes (a pass run several times, like the occlusion
// sampling passes of a culling iteration, summed).
struct FrameGpu {
  double ms = 0.0;
  std::map<std::string, double> passes;
};

struct FrameReport {
  uint64_t frame = 0;             // counts from 0 over the renderer's life
  uint32_t samples = 0;           // samples accumulated in the current image
  bool accumulated = false;       // this frame added a sample
  bool culling_active = false;    // this frame ran a culling iteration
  bool culling_converged = false; // the current view's culling converged (Sect. 5.3)
  bool complete = false;          // streaming: every wanted node resident (or failed), nothing in flight
  bool converged = false;         // culling_converged && complete (in-memory: culling_converged or no culling)
  // The view's culling has stopped -- converged, or --max-iterations reached without converging
  // (classes kept) -- and streaming is complete: until a new view or new data, frames only add
  // samples. The viewer rests (and a playing series steps on) once settled and accumulated.
  bool settled = false;
  double gpu_ms = 0.0;            // GPU time of the PREVIOUS frame's passes (known once it completed; 0: not timed)
  double wall_ms = 0.0;           // CPU wall time of step()
  double wait_ms = 0.0;           // of it: waiting for the previous frame's command buffer
  double cache_ms = 0.0;          // of it: the streaming cache's update (reads placed, uploads recorded, prefetch)
  uint32_t class_counts[4] = {};  // meshlets P, L, M, O after the last classification
  uint32_t node_class_counts[4] = {};
  uint32_t nodes_uploaded = 0;    // this frame
  uint64_t bytes_uploaded = 0;    // this frame
  uint32_t frame_hits = 0, frame_misses = 0;  // this frame's wanted nodes resident / not
  uint32_t reads_requested = 0;   // node reads this frame's prefetch submitted
  uint32_t upload_regions = 0;    // copy regions of the pool's transfers this frame (pass "upload")
  bool upload_stall = false;
  bool budget_exhausted = false;  // streaming: this frame wanted more nodes than the pool holds
  std::vector<uint32_t> wanted;   // StreamSettings::record_trace: this frame's wanted nodes
  std::vector<uint8_t> wanted_hit;  // parallel to wanted: 1 = resident when this frame drew (a hit)
  // The occlusion sampling passes this frame recorded by route, the probe among them (-1 none,
  // 0 rasterized, 1 compute) and its budget divisor, and each route's GPU ms per pass in the last
  // finished comparison (-1: none; what the automatic route choice decides by: docs/rendering.md).
  uint32_t sample_passes_raster = 0, sample_passes_compute = 0;
  int sample_probe = -1;
  uint32_t sample_probe_share = 0;
  double sample_compared_ms_raster = -1.0, sample_compared_ms_compute = -1.0;

  // What the frame pacer needs of this frame (FramePacer::observe).
  FrameLoad load() const { return {frame_hits, frame_misses, budget_exhausted}; }
};

struct RenderStats {
  std::string device;
  uint64_t particles = 0;
  uint64_t meshlets = 0;
  uint32_t spp = 0;
  uint32_t width = 0, height = 0;
  std::map<std::string, double> pass_ms_median;  // GPU timestamps per pass, median over passes
  double frame_ms_median = 0.0;                  // sum of the pass medians
  double wall_ms = 0.0;                          // CPU wall time of all passes incl. readback
  uint64_t upload_bytes = 0;
  uint64_t device_bytes = 0;
  double near = 0.0, far = 0.0;
  bool mesh_sprites = false;  // sprites drawn by the task/mesh path (else compute + indirect draws)
  bool visibility_route = false;  // pixels by the visibility buffer (else colour + depth attachments)
  bool ambient_occlusion = false;  // the resolve applied RenderSettings::ao_* (the visibility route only)
  bool accumulation_buffer = false;  // accumulation in a storage buffer (else a storage image)
  bool covered_pixel_list = false;   // the last frame's resolve ran over the listed covered pixels (else full screen)
  uint32_t sprite_chunks = 1;        // chunks a frame's draw list is drawn in (RenderSettings::sprite_capacity)
  double covered_fraction = -1.0;    // covered pixels / pixels by the view's probe (-1: not probed)
  // The sprite pre-pass of the last drawn frame (compute path; zeros on the task/mesh path):
  // particles of the listed meshlets, those with nothing to draw (behind the near plane, off
  // screen, beyond the far plane: sprite_make.h), those rasterized in compute (small sprites).
  uint64_t sprites_listed = 0, sprites_offscreen = 0, sprites_small = 0;
  CullStats cull;
  CacheStats cache;                 // streaming only
  double frame_wall_ms_p50 = 0.0;   // CPU wall time per frame (step), all frames of the render
  double frame_wall_ms_p99 = 0.0;
  uint32_t frames = 0;
};

class Renderer {
 public:
  // In-memory: every particle of `scene` is uploaded.
  static Result<std::unique_ptr<Renderer>> create(vk::Context& ctx, const SceneData& scene,
                                                  const RenderSettings& settings);
  // Out-of-core: node payloads stream from `reader` (which must outlive the renderer) through a
  // pool of stream.gpu_budget bytes; the node directory and the density volume stay resident.
  // Errc::budget when the budget cannot hold the largest node.
  static Result<std::unique_ptr<Renderer>> create_streaming(vk::Context& ctx, const store::StoreReader& reader,
                                                            const RenderSettings& settings,
                                                            const StreamSettings& stream);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders settings.spp jittered frames (plus culling-only iterations until convergence, see
  // the file comment) and returns the averaged image. The camera's near/far are fitted to the
  // scene bounds when unset.
  // Streaming: frames run until the view has converged with every wanted node resident, then
  // spp samples are accumulated (an upload restarts the accumulation).
  Result<FrameImage> render(const Camera& camera, RenderStats* stats = nullptr);

  // Progressive API (viewer, stress). set_view() starts a new view when the camera differs from
  // the current one (classes restart, accumulation restarts; the cache stays); step() runs one
  // frame: streaming update, a culling iteration while culling is active, draw, accumulate.
  // Accumulation restarts on a new view and, when streaming, on any frame that uploaded nodes.
  Status set_view(const Camera& camera);
  // Streaming, camera path replays (stress, a viewer playing a path): the views that follow the
  // next set_view()'s camera, when the caller knows them (the first
  // StreamCache::kLookaheadFrames are used). The cache then treats a view whose next views
  // differ as moving from its first frame and looks ahead along the path instead of
  // extrapolating (StreamCache::set_view). Kept until the next call; empty (the default): not known.
  void set_path_next(std::span<const Camera> next);
  static constexpr uint32_t kPathNextViews = 3;  // views set_path_next uses (StreamCache::kLookaheadFrames)
  Result<FrameReport> step();
  // Waits until the frame in flight (the last step()) has finished on the device, and collects
  // its GPU timestamps (last_frame_gpu()).
  Status finish();
  // The passes of the last frame whose GPU work completed and was collected (by finish(), the
  // next step() or set_view()); zeros when timestamps are not available.
  FrameGpu last_frame_gpu() const;
  // The current accumulated image (average of FrameReport::samples samples), at the current size.
  Result<FrameImage> read_image();
  // Changes the render size without re-creating the renderer (window resize; dynamic resolution,
  // render/frame_pacer.h). Only the size-dependent resources are rebuilt: the colour, depth and
  // accumulation targets, the small-sprite visibility buffer, and the culling loop's per-pixel
  // state (CullLoop::resize: histograms, cull/accumulation buffers, pyramid, sample image).
  // Everything sized by the scene or the budget stays: the streaming cache (pool, resident
  // nodes, reads in flight, its classes), the node directory, the density volume, pipelines.
  // The current view restarts (accumulation and culling classes, as for a new camera) at the
  // next set_view() or step(). Reallocating instead of rendering into a sub-rectangle of fixed
  // targets keeps every pass exactly as at a fixed size (the pyramid, histograms and jitter
  // are defined over the whole target), so an image after returning to a size equals one that
  // never left it; on lavapipe the reallocation costs a few ms at 320x180, well below a frame.
  // Waits for the frame in flight. Errc::invalid_argument outside 1..16384.
  Status resize(uint32_t width, uint32_t height);
  // The viewer's keys, without re-creating the renderer (so a streaming cache survives):
  // C_occ in (0, 1) -- with culling, the current view restarts at the next step() (classes only
  // move upward within a view); spp >= 1 -- the accumulation goes on to the new count (or
  // stops where it is, if that is already more). Errc::invalid_argument outside those ranges.
  Status set_c_occ(double c_occ);
  Status set_spp(uint32_t spp);
  // Ambient occlusion (RenderSettings::ao_radius, ao_strength; strength 0: off) in place: the
  // accumulation restarts at the next step(); culling and the cache are untouched (the classes
  // do not depend on shading). Errc::invalid_argument for a negative or non-finite value.
  Status set_ambient_occlusion(double radius, double strength);
  // What colours the particles (RenderSettings::color_by, resolved against the store:
  // render::resolve_color_by), in place like set_ambient_occlusion: the accumulation restarts,
  // culling and the cache are untouched. Errc::invalid_argument as Renderer::create gives it
  // (the property or the colours asked of a store without them); Errc::unsupported for the
  // colours on a streaming renderer whose pool holds none (StreamSettings::colors: re-create it).
  Status set_color_by(const ColorBy& color_by);
  // The simulation cell drawn (RenderSettings::cell; none: not drawn), in place: the
  // accumulation restarts, and the view restarts at the next step() with its clip planes fitted
  // to the new clip_bounds() (culling starts again; the cache stays). Errc::invalid_argument for
  // a cell with a non-finite value.
  Status set_cell(const std::optional<SimulationCell>& cell);
  // The sample-area model (culling::CullSettings::coverage), in place like set_c_occ: with
  // culling, the current view restarts at the next step() with the new model.
  Status set_coverage(culling::Coverage coverage);
  // Camera in motion (dynamic resolution, render/frame_pacer.h): one occlusion sampling pass per
  // culling iteration instead of RenderSettings' count -- a moving frame is a new view whose
  // classes never mature, so the extra passes cost time (a fixed cost per particle, not per
  // pixel) and buy nothing; at rest (false) the configured count returns, paced by
  // RenderSettings::pace_sampling. step() applies it to each iteration it records.
  // sample_share in (0, 1]: while moving, each sampling pass selects that share of the culling
  // loop's occluder budget (CullLoop::set_moving); the dynamic resolution passes
  // FramePacer::sample_share(), the render size's share of the full size's pixels.
  void set_motion(bool moving, double sample_share = 1.0);
  uint32_t width() const;
  uint32_t height() const;
  // Statistics so far (pass times over the frames since the last set_view()).
  RenderStats stats() const;
  const Bounds& bounds() const;
  // The bounds the views' clip planes are fitted to (fit_clip_planes): bounds() and the cell's
  // corners where the cell is drawn (RenderSettings::cell). A caller comparing with
  // read_last_depth() fits its camera to these.
  const Bounds& clip_bounds() const;
  // The colormap's [lo, hi] with RenderSettings::color_by along an axis: the settings' range, or
  // the bounds of the particle centres along the axis when unset (a flat axis widened by 1e-9
  // of the extent so that lo < hi); (0, 0) when colouring by type.
  glm::dvec2 color_range() const;
  // Streaming: device bytes each node occupies when resident (the cache's unit of accounting,
  // for offline simulations of the same budget); empty when in memory.
  std::vector<uint64_t> node_device_bytes() const;
  // node_device_bytes() with each node that --slice cuts at the pages of what it keeps, also the
  // cut nodes the cache has not read: those are read and thinned here, on the calling thread
  // (offline bounds of `stress`; StreamCache::node_device_bytes_kept). Empty when in memory.
  Result<std::vector<uint64_t>> node_device_bytes_kept() const;
  // Streaming: 1 for each node whose payload is in the device pool now, else 0 (the viewer's
  // resident-bounds view); empty when in memory.
  std::vector<uint8_t> resident_nodes() const;
  // Streaming: what the cache knows of the current view (every node's world box, and whether the
  // view wants it), for the renderer of the next store of a series (StreamSettings::prior); null
  // when in memory.
  std::shared_ptr<const streaming::PriorView> prior_view() const;
  // Streaming: every node of the store as the cache saw it (NodeLogEntry); empty when in memory.
  std::vector<NodeLogEntry> node_log() const;
  bool streaming() const;
  // Depth buffer (z_ndc, 1 = background) of the last drawn frame (render() or step()), row-major
  // from the top-left; waits for the frame in flight.
  Result<std::vector<float>> read_last_depth();
  // The culling loop (null without RenderSettings::cull).
  culling::CullLoop* cull_loop();
  // Called after each culling iteration has completed on the GPU, with its index (counting from
  // 0 per render()); the loop's buffers can be inspected through cull_loop() from it.
  void set_iteration_hook(std::function<void(uint32_t)> hook);

 private:
  Renderer() = default;
  Result<FrameImage> render_streaming(const Camera& camera, RenderStats* stats);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mds::render
