// The sphere-glyph renderer (no culling yet). One frame = one super-sampling pass:
//   1. "draw_list": a compute pass fills the draw list (DrawListHeader + meshlet ids) -- today
//      every meshlet (draw_list_all.comp); the culling loop will plug its classification in here
//      and may issue several lists per frame;
//   2. "draw": one vkCmdDrawIndexedIndirect over the list: vertex-pulled billboards (4 vertices,
//      6 indices per particle, one instance per meshlet), ray-cast spheres with exact depth,
//      rendered with a Halton(2,3) sub-pixel jitter in the projection;
//   3. "accumulate": a compute pass adds the pass's colour (a = coverage) into a float32 image.
// The written image is accumulation / spp. GPU timestamps are recorded per pass.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "core/result.h"
#include "render/camera.h"
#include "render/culling/cull_loop.h"
#include "render/culling/density_volume.h"
#include "render/scene.h"
#include "vk/context.h"

namespace mds::render {

struct RenderSettings {
  uint32_t width = 1920;
  uint32_t height = 1080;
  uint32_t spp = 64;
  glm::vec3 background_srgb{0.12f, 0.12f, 0.13f};  // default: dark grey
  bool cull = false;                                 // probabilistic occlusion culling (false: --no-cull)
  culling::CullSettings cull_settings;
  std::shared_ptr<const culling::DensityVolume> density;  // from the store; null: built from the scene
};

// Culling loop statistics of one render() (RenderStats::cull).
struct CullStats {
  bool enabled = false;
  bool converged = false;
  uint32_t iterations = 0;
  uint32_t iterations_to_converge = 0;
  uint32_t samples_to_converge = 0;
  uint32_t bins = 0;
  uint32_t budget = 0;
  uint64_t meshlets_culled = 0;
  std::vector<uint32_t> class_counts;  // P, L, M, O after the last classification
  std::vector<uint32_t> changed_per_iteration;
  std::vector<uint32_t> culled_per_iteration;
  double time_to_converge_ms = 0.0;
  double frame_ms_during_culling = 0.0;
  double frame_ms_after_convergence = 0.0;
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
  CullStats cull;
};

class Renderer {
 public:
  static Result<std::unique_ptr<Renderer>> create(vk::Context& ctx, const SceneData& scene,
                                                  const RenderSettings& settings);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders settings.spp jittered passes and returns the averaged image. The camera's near/far
  // are fitted to the scene bounds when unset.
  Result<FrameImage> render(const Camera& camera, RenderStats* stats = nullptr);
  // Depth buffer (z_ndc, 1 = background) of the last pass, row-major from the top-left.
  Result<std::vector<float>> read_last_depth();
  // The culling loop (null without RenderSettings::cull).
  culling::CullLoop* cull_loop();
  // Called after each culling iteration has completed on the GPU, with its index.
  void set_iteration_hook(std::function<void(uint32_t)> hook);

 private:
  Renderer() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mds::render
