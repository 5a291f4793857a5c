// The probabilistic occlusion culling loop on the GPU (paper 000, Ibrahim et al. 2021, Sect. 3-5,
// Algorithm 1; supplement 004 A), as compute passes and indirect draws (no mesh shaders needed).
// One culling iteration (record_iteration) is:
//   samples_per_iteration occlusion sampling passes (Sect. 3.2: "In each iteration, we perform
//   multiple passes of choosing a subset of potential occluders"), each:
//     select  occluder selection from P, then L, random per pass (Sect. 5.2) -> occluder list
//     sample  one jittered depth sample per pixel of the occluders (depth + alpha_s, indirect draw)
//     update  Algorithm 1 per pixel with P(d_s) of Eq. 13-22 (accumulation + cull buffer)
//   then once:
//   pyramid   Eq. 23, level by level
//   classify  nodes, then meshlets into O/M/L/P (Sect. 5.1); meshlets reaching O subtract their
//             voxel contributions from the density volume (Sect. 4.4)
//   histogram per-pixel density histograms (Eq. 9-11), recomputed when the volume changed.
//             Sect. 3/4.4 update the volume "after each iteration of determining occlusion
//             classes"; doing it once per iteration (not per sampling pass) is what the paper
//             requires, and amortises the ray cast over the iteration's passes. Recorded at the
//             start of the next iteration of the same view (before its sampling passes), so a
//             view that ends -- a moving camera starts a new one every frame -- skips it.
// A view starts with its reset (classes to P, the original density volume, histograms cast):
// begin_view submits it at once; prepare_view leaves it to the next record_iteration, which
// records it first (pass "view"), in the frame's own command buffer.
// record_draw_list writes the potentially visible set (all meshlets not in O) into a draw list
// in the renderer's format. The host decides convergence (Sect. 5.3) from counters() read after
// each iteration: no meshlet changed class for `converge_iterations` iterations.
//
// Resident set: per-meshlet arrays are indexed by meshlet slot. In memory every meshlet of the
// scene has a slot; streaming (src/render/streaming/node_pool.h) the slots are the pool's pages,
// empty slots (particle_count 0) are skipped by every pass, so the sampling and the meshlet
// classification run only over resident nodes, while the node classification covers every node
// of the store (the directory stays resident). Density updates are per meshlet in memory and per
// node when streaming (CullScene::node_density).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <vulkan/vulkan.h>

#include "core/result.h"
#include "cull_shared.h"
#include "culling/culling_constants.h"
#include "render/camera.h"
#include "render/culling/density_volume.h"
#include "render/culling/sample_route.h"
#include "render/scene.h"
#include "vk/context.h"
#include "vk/timestamps.h"

namespace mds::render::culling {

// Defaults of the loop's free parameters (the paper leaves them open; measured on lavapipe with
// the porous/ablation scenes, see docs/culling-math.md "Loop parameters").
inline constexpr uint32_t kDefaultSamplesPerIteration = 4;
inline constexpr uint32_t kDefaultConvergeIterations = 3;
inline constexpr uint32_t kDefaultBudgetDivisor = 8;
inline constexpr uint32_t kDefaultMaxIterations = 256;
// Streaming, at rest: a sampling pass draws at most this share of the resident meshlets
// (CullSettings::max_resident_share, CullLoop::set_resident_meshlets; docs/streaming.md,
// "Occluder share of a filling cache").
inline constexpr double kDefaultMaxResidentShare = 0.5;

// Occluder meshlets per sampling pass when CullSettings::budget is 0: 2 per node (paper Tables
// 3/4, "b = 2 meshlets/node"), at least meshlets / kDefaultBudgetDivisor: the paper's nodes hold
// 10^4 particles of 10^8 (b = 2 per node is then ~1/300 of the meshlets, with many particles per
// pixel); our scenes have ~1-4 particles per pixel along a ray, so a pass must draw a larger
// share of the candidates to hit every pixel's front layer within a few dozen passes.
uint32_t default_budget(uint32_t nodes, uint32_t meshlets);

// SampleRoute, the route choice and its constants: render/culling/sample_route.h.

enum class Coverage { expected, exact, automatic };
// The CLI's names: "expected", "exact", "auto".
inline std::string coverage_name(Coverage c) {
  return c == Coverage::exact ? "exact" : c == Coverage::automatic ? "auto" : "expected";
}
inline std::optional<Coverage> parse_coverage(const std::string& name) {
  for (Coverage c : {Coverage::expected, Coverage::exact, Coverage::automatic})
    if (coverage_name(c) == name) return c;
  return std::nullopt;
}

struct CullSettings {
  double c_occ = MDS_CULL_C_OCC_DEFAULT;        // --cocc
  double c_medium = MDS_CULL_C_MEDIUM_DEFAULT;  // L/M boundary (docs/culling-math.md)
  int acceptance = MDS_CULL_ACCEPT_NORMAL;      // or MDS_CULL_ACCEPT_RANDOM (--acceptance random)
  uint32_t n_budget = MDS_CULL_N_BUDGET_DEFAULT;
  uint32_t budget = 0;  // occluder meshlets per sampling pass; 0: default_budget()
  // Streaming, at rest, with budget 0: at most this share (0, 1] of the resident meshlets per
  // sampling pass (set_resident_meshlets); 1: the default budget alone.
  double max_resident_share = kDefaultMaxResidentShare;
  uint32_t samples_per_iteration = kDefaultSamplesPerIteration;  // sampling passes per iteration (Sect. 3.2)
  uint32_t converge_iterations = kDefaultConvergeIterations;      // Sect. 5.3: iterations without class changes
  uint32_t max_iterations = kDefaultMaxIterations;  // cap when not converged (the renderer keeps iterating past spp)
  uint32_t bins = 0;                 // histogram bins; 0: as many as fit (<= 64), see bins_for()
  // Pixels per side of a density histogram block: one histogram (Eq. 9-10, cast along the block
  // centre's ray) serves s x s pixels. 1 = per pixel, as the paper. The density volume's cells
  // cover many pixels (~1M voxels for a whole data set), so neighbouring pixel rays cross the same
  // cells; 2 casts a quarter of the rays (docs/culling-math.md, "Histogram blocks").
  uint32_t histogram_stride = 2;
  // Sect. 4.1 "Particle sizes": alpha_s of an occlusion sample. expected: the paper's expected
  // area of the particle in the pixel (culling_math.h effective_particle_area), histograms
  // counting particle centres (Eq. 9). exact (--coverage exact): the sample's particle clipped
  // against its pixel (disk_pixel_coverage), histograms counting every particle that can reach
  // the pixel (footprint grown by the smallest radius), and Algorithm 1 with the depth extension
  // (confidence_buffer.h extend_accumulation). Exact loses fewer visible particles where
  // particles are about a pixel wide and culls less where they are large. automatic (--coverage
  // auto, the CLI's default): each sample by its own particle's projected size, exact clipping
  // below kMixedExactBelowPx and the expected area above (mixed_pixel_coverage), with exact's
  // histograms and extension. docs/culling-math.md "Particle sizes".
  Coverage coverage = Coverage::expected;
  uint32_t seed = 1;
  // Route of the occlusion sampling pass (docs/rendering.md): rasterized billboards
  // (cull_sample.vert/.frag) or compute (cull_sample.comp, needs 64-bit buffer atomics and W*H*8
  // bytes in one storage buffer). Both give the same samples (tested). automatic: measured --
  // the passes of one iteration alternate between the routes, timed on the GPU, and the faster
  // one runs until the next comparison kSampleRouteExplore iterations later.
  // MDSTREAM_CULL_SAMPLE=raster|compute overrides automatic (A/B measurements).
  SampleRoute sample_route = SampleRoute::automatic;
  // Compute route: the update (Algorithm 1) runs over a list of the pixels that received a sample
  // (cull_sample_compact.comp) instead of every pixel (lavapipe runs a skipped branch anyway,
  // docs/rendering.md). Needs subgroup ballots in compute. Both give the same state (tested).
  // MDSTREAM_CULL_UPDATE=full overrides it (A/B measurements). Where the last count found
  // kSampledListMaxFraction or more of the pixels sampled, only the probe passes take the list
  // (cull_loop_impl.h).
  bool sampled_pixel_list = true;
};
// Sampled pixels / pixels above which the full-screen update is used. 1080p ablation 1M, per
// sampling pass: full screen ~80-100 ms; the list ~12 ms of compaction plus ~200 ms x fraction
// (scattered access): 42 ms at ~15 % sampled (view 1), ~170 ms at ~95 % (view 2); even at ~0.4.
inline constexpr double kSampledListMaxFraction = 0.35;
// Iterations between two probes of the sampled fraction (the first pass of the iteration).
inline constexpr uint32_t kSampledListProbeIterations = 8;

// The renderer's scene buffers the culling passes read (and the draw list they write).
// meshlet_class: the per-slot class buffer when its owner is the streaming pool (which resets
// the classes of the slots it fills); VK_NULL_HANDLE: the loop allocates its own.
struct SceneBuffers {
  VkBuffer nodes = VK_NULL_HANDLE, meshlets = VK_NULL_HANDLE, particles = VK_NULL_HANDLE;
  VkBuffer types = VK_NULL_HANDLE, radii = VK_NULL_HANDLE, draw_list = VK_NULL_HANDLE;
  VkBuffer meshlet_class = VK_NULL_HANDLE;
};

// Pyramid texels per side at most in a node's box test (cull_classify.comp, specialization
// constant 0; the meshlets' is 32). In memory a node's class only spares the classification of
// its meshlets, so 32 (<= 1024 ray tests per node). When streaming it decides which nodes are
// read, and a node tested at a coarse level stays in front of the cull depth through the far
// texels next to it: 128 (<= 16384 tests per node) read 1.10 instead of 1.18x the bytes of the
// nodes holding a visible particle on the porous 1M view 0 at 640x360 (docs/streaming.md).
inline constexpr uint32_t kNodeExtentInMemory = 32;
// Smallest subgroup whose lanes share large box tests by default (cull_classify_coop.comp).
// Lavapipe's subgroups of 8 lose with it: the ablation 1M jumps' classification 0.46 -> 0.63 s
// over 48 frames at 320x180, and 0.59 s even with no box shared (the variant alone).
inline constexpr uint32_t kCooperativeBoxesMinSubgroup = 32;
// Histogram block side of a view begun while the camera moves (CullLoop::set_moving): a quarter
// of the rays of the default 2. Porous 1M stress fly-through, 320x180: median frame 35 -> 27 ms,
// the same bytes read and hit rate (docs/viewer.md).
inline constexpr uint32_t kMovingHistogramStride = 4;
inline constexpr uint32_t kNodeExtentStreaming = 128;

// What the loop needs to know of the scene: sizes, radius encoding, and the static voxel lists of
// the density updates (Sect. 4.4) as CSR, per meshlet slot or per node (node_density).
struct CullScene {
  glm::dvec3 origin{0.0};
  uint32_t meshlet_slots = 0;  // size of the per-meshlet arrays
  uint32_t node_count = 0;
  uint32_t max_meshlet_particles = 0;
  bool per_particle_radius = false;
  float radius_min = 0.0f, radius_max = 0.0f;
  // The density histograms count the particles whose disk can reach a pixel: the footprint grown
  // by this radius (culling_math.h footprint_count; render/scene.h smallest_radius).
  float footprint_radius = 0.0f;
  bool node_density = false;
  uint32_t node_extent = kNodeExtentInMemory;  // kNodeExtentStreaming when streaming
  std::vector<uint32_t> voxel_first;  // meshlet_slots + 1 (node_count + 1 with node_density)
  std::vector<glm::uvec2> voxel_refs;  // (voxel, particle count)
};
// In memory: every meshlet of `scene` in its own slot, per-meshlet voxel lists.
CullScene cull_scene(const SceneData& scene, const DensityVolume& volume);

// Histogram bins that fit: W*H*bins*4 bytes must stay within maxStorageBufferRange (the
// histogram buffer is bound whole). lavapipe: 128 MiB -> 64 bins up to 524288 pixels
// (640x360: 59 MiB), 16 bins at 1920x1080 (2073600 px * 16 * 4 = 127 MiB).
uint32_t bins_for(uint32_t width, uint32_t height, uint64_t max_storage_range, uint32_t requested);

class CullLoop {
 public:
  static Result<std::unique_ptr<CullLoop>> create(vk::Context& ctx, const CullScene& scene,
                                                  const DensityVolume& volume, const SceneBuffers& buffers,
                                                  uint32_t width, uint32_t height, const CullSettings& settings);
  static Result<std::unique_ptr<CullLoop>> create(vk::Context& ctx, const SceneData& scene,
                                                  const DensityVolume& volume, const SceneBuffers& buffers,
                                                  uint32_t width, uint32_t height, const CullSettings& settings);
  ~CullLoop();
  CullLoop(const CullLoop&) = delete;
  CullLoop& operator=(const CullLoop&) = delete;

  // New view: all classes P, empty cull/accumulation buffers, the original density volume,
  // histograms cast. `camera` must have near/far set. Submits and waits.
  // live_meshlets: occupied slots (the initial |P| of the occluder selection); default all.
  Status begin_view(const Camera& camera, uint32_t live_meshlets = UINT32_MAX);
  // The same without a submission of its own: sets the view's uniforms now, and the next
  // record_iteration() records the view's GPU reset first, in the frame's command buffer (pass
  // "view" of its timestamps). The renderer's frames use it: a moving camera begins a view every
  // frame, and a submit-and-wait of its own cost each of them a round trip to the device, with
  // GPU work (on lavapipe 1.3-7 ms per view) that no timestamp saw. Until that iteration is
  // recorded the loop's buffers hold the previous view (counters(), node_classes(), the read_*
  // hooks). Errc::invalid_argument as begin_view.
  Status prepare_view(const Camera& camera, uint32_t live_meshlets = UINT32_MAX);
  // Runs begin_view and one culling iteration with `camera` (submits and waits), then forgets
  // them: the first view's frame no longer pays the first use of the culling pipelines and
  // buffers (docs/streaming.md "Warm-up"). Call before the first begin_view; that view starts
  // from the same state as without the warm-up (the sampling-route choice included).
  Status warm_up(const Camera& camera);
  // One culling iteration (see the file comment) into cmd; `iteration` counts from 0 per view;
  // its sampling passes are numbered iteration * settings().samples_per_iteration + p (unique
  // whatever set_samples_per_iteration chose: the renderer paces the passes at rest).
  // Ends with a copy of the counters for counters(). Timestamps per pass when ts != nullptr.
  void record_iteration(VkCommandBuffer cmd, vk::TimestampPool* ts, uint32_t iteration);
  // Appends every meshlet not in O to `draw_list` (header must be reset by the caller).
  void record_draw_list(VkCommandBuffer cmd);
  // Counters of the last recorded iteration (valid after its submission completed).
  gpu::CullCounters counters() const;
  // Node classes after the last recorded iteration (valid after its submission completed).
  std::span<const uint32_t> node_classes() const;
  uint32_t meshlet_slots() const;

  uint32_t bins() const;
  // Occluder meshlets per sampling pass at rest: CullSettings::budget, default_budget(), or the
  // cap of set_resident_meshlets.
  uint32_t budget() const;
  // Streaming: `live` meshlets are resident (the pool's occupied slots). With CullSettings::
  // budget 0, max_resident_share < 1 and `filling` (the pool has room for any node, and the view
  // wants no more than it holds or has had its first sampled iteration: Renderer), a sampling
  // pass at rest draws at most that share.
  // default_budget() counts the store's nodes and the pool's slots, and while the cache fills
  // it exceeds what is resident: every resident meshlet was drawn in every pass, a pixel then
  // only ever sampled its frontmost resident particle, and where that particle covers part of
  // the pixel its confidence stayed short of c_occ (Sect. 4.3, Eq. 8: the samples are meant to
  // be random draws of the particles in front). A full pool, or a view that wants more than it
  // holds, keeps the whole budget (measured: the cap slowed the views held after jumps at a
  // small pool and raised their frame p99 / p50: a capped first iteration leaves most meshlets
  // in P, and the passes after it draw more), and so does a moving camera (one iteration per
  // view). Takes effect from the next recorded iteration.
  void set_resident_meshlets(uint32_t live, bool filling);
  // Sampling passes recorded with the compute / rasterized route (this loop's lifetime).
  uint32_t sample_route_passes(SampleRoute route) const;
  // The classification shares large box tests over subgroups (cull_classify_coop.comp).
  bool shared_box_tests() const;
  // The node classification runs one subgroup per node (cull_classify_coop.comp push.mode 2).
  bool node_per_subgroup() const;
  // A shared test's occupied cells go one after the other, each cell's texels over the subgroup
  // (cull_classify.comp kSharedCells; on where box tests are shared, MDSTREAM_CULL_SHARED_CELLS=0 off).
  bool shared_cells() const;
  // GPU ms per sampling pass of the route in the last finished comparison (-1: none).
  double sample_route_ms(SampleRoute route) const;
  // The sampling passes recorded since the last call, by route, and the probe among them
  // (kSampleRouteProbeShare: a pass of the other route that only measures); then cleared. The
  // renderer reports them per frame (FrameReport::sample_routes, `stress` per_frame.sample_route).
  struct SampleRoutes {
    uint32_t raster = 0, compute = 0;  // passes whose samples count
    int probe = -1;                    // -1 none, 0 rasterized, 1 compute
    uint32_t probe_share = 0;          // the probe's budget divisor (sample_route_probe_share)
  };
  SampleRoutes take_sample_routes();
  // After an iteration completed on the GPU (before the next is recorded): reads the timestamps
  // of a route comparison (automatic route choice). A no-op otherwise.
  Status collect_route_timings();
  uint32_t samples_per_iteration() const;
  uint32_t pyramid_levels() const;
  // The confidence pyramid (all levels, vec2 (d, C) per texel; cull_bindings.h): the renderer's
  // particle occlusion test reads it after convergence. Replaced by resize().
  VkBuffer pyramid_buffer() const;
  const CullSettings& settings() const;
  uint32_t width() const;
  uint32_t height() const;

  // Dynamic resolution (render/frame_pacer.h): re-creates only the per-pixel state (density
  // histograms and their ranges, cull/accumulation buffers, confidence pyramid, the occlusion
  // sample image and its depth) at width x height; the scene-sized state (density volume, voxel
  // lists, meshlet/node classes, pipelines) stays. The caller must have waited for the GPU to
  // finish with the loop, and must call begin_view() before the next iteration.
  Status resize(uint32_t width, uint32_t height);
  // Changes C_occ (the O threshold of Sect. 5.1) from the next recorded iteration on. Classes
  // only move upward within a view, so the caller restarts the view (begin_view()).
  void set_c_occ(double c_occ);
  void set_coverage(Coverage coverage);  // takes effect at the next begin_view
  // Occlusion sampling passes per iteration from the next recorded iteration on, in
  // 1..settings().samples_per_iteration (the timestamp pool is sized for that many).
  void set_samples_per_iteration(uint32_t passes);
  // Camera in motion (Renderer::set_motion): nodes are tested at kNodeExtentInMemory texels per
  // side whatever CullScene::node_extent says. A moving frame's classes never mature (the cache
  // takes only its confident O), and inside the data the 128-texel tests of the nodes around the
  // eye cost the classification ~20 ms per 320x180 frame instead of ~5.
  // A view begun while moving also casts its density histograms per kMovingHistogramStride^2
  // block (begin_view); when the camera comes to rest on it, the next iteration casts them again
  // per configured block (the classes stay), so the refinement at rest runs on render()'s blocks.
  // budget_share in (0, 1]: while moving, each sampling pass selects that share of budget()
  // (at least one meshlet; out of range: 1). The dynamic resolution passes the render size's
  // share of the full size's pixels (FramePacer::sample_share): a pass's cost is per occluder
  // particle, so without it a frame at 1/8 scale still paid the full size's sampling, and a
  // smaller image needs fewer samples for the same samples per pixel. At rest: the whole budget.
  void set_moving(bool moving, double budget_share = 1.0);
  // Occluder meshlets per sampling pass of the next recorded iteration: budget(), or its share
  // while moving (set_moving).
  uint32_t pass_budget() const;
  uint32_t view_histogram_stride() const;

  // Inspection and test hooks (each submits and waits).
  Result<std::vector<uint32_t>> read_meshlet_classes();
  Result<std::vector<float>> read_histograms();    // W*H*bins per-bin counts (stored cumulative)
  Result<std::vector<glm::vec2>> read_hist_ranges();
  Result<std::vector<glm::vec4>> read_pixel_state();  // 2 per pixel
  Result<std::vector<glm::vec2>> read_pyramid();      // all levels
  Result<std::vector<int32_t>> read_volume();
  // Per-bin counts (W*H*bins); stored as cumulative sums.
  Status write_histograms(const std::vector<float>& counts, const std::vector<glm::vec2>& ranges);
  Status write_pyramid_level0(const std::vector<glm::vec2>& dc);
  // Sets the sample image (view depth, alpha_s) and runs only the update pass as sampling pass
  // number `iteration` (its random numbers).
  Status run_update_only(const std::vector<glm::vec2>& samples, uint32_t iteration);
  // Runs one occlusion sampling pass, number `pass` (its jitter and occluder selection), on the
  // current classes, by the route CullSettings::sample_route forces (automatic: raster), and
  // returns its samples: W*H (view depth of the nearest hit, alpha_s), (MDS_CULL_DEPTH_EMPTY, 0)
  // where no particle was hit.
  Result<std::vector<glm::vec2>> run_sampling_pass_only(uint32_t pass);
  Status run_pyramid_only();
  Status run_histogram_only();

 private:
  CullLoop() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mds::render::culling
