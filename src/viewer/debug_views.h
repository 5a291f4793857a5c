// Debug views of the viewer (keys 2/3/4, B, D), drawn on the CPU into the 8-bit frame from the
// culling loop's inspection hooks (render::culling::CullLoop::read_*; each submits and waits,
// fine for a debug view) and the scene's node/meshlet bounds:
//   classes     per pixel, the occlusion classes (P green, L yellow, M orange, O red) of the
//               meshlets whose projected bounding boxes cover it, mixed by count (red: most
//               of what lies behind the pixel is culled), over the dimmed image;
//   cull depth  the cull buffer's depth d_cull per pixel (Algorithm 1), near white .. far black,
//               empty pixels dark blue;
//   confidence  the cull buffer's confidence C_cull per pixel, black 0 .. white 1, with C_occ
//               marked: pixels at or above it are tinted red;
//   bounds      the nodes' boxes as projected lines;
//   histogram   the density histogram (Eq. 9-11) of the pixel under the cursor, as bars.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "core/result.h"
#include "render/camera.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "overlay/canvas.h"

namespace mds::viewer {

using overlay::Canvas;
using overlay::Rgba8;

enum class DebugView { normal = 1, classes = 2, cull_depth = 3, confidence = 4 };
const char* debug_view_name(DebugView v);

struct Box {
  glm::dvec3 min{0.0}, max{0.0};  // world coordinates
};

// Colour of an occlusion class (MDS_CULL_CLASS_*), opaque.
Rgba8 class_color(uint32_t cls);

// World -> pixel projection of a camera (near/far fitted) for a canvas size; false: behind the eye.
class Projector {
 public:
  Projector(const render::Camera& camera, uint32_t width, uint32_t height);
  bool project(const glm::dvec3& world, glm::dvec3& pixel_and_depth) const;  // x, y pixels; z = z_ndc

 private:
  glm::dmat4 view_proj_;
  uint32_t width_, height_;
};

// Box edges as lines (edges crossing the near plane are clipped in view space).
void draw_box(Canvas& canvas, const Projector& proj, const render::Camera& camera, const Box& box, Rgba8 color);

// Occlusion classes of boxes (world coordinates), classes[i] for boxes[i] (values > 3 are
// skipped): per pixel, the class colours mixed by how many boxes of each class its ray passes
// through (their projected rectangles), brighter with more boxes, over the dimmed image.
void draw_class_boxes(Canvas& canvas, const render::Camera& camera, std::span<const Box> boxes,
                      std::span<const uint32_t> classes);
// In-memory scene: meshlet classes. `classes` indexed like scene.meshlets.
void draw_meshlet_classes(Canvas& canvas, const render::Camera& camera, const render::SceneData& scene,
                          const std::vector<uint32_t>& classes);
// Pixel state (2 vec4 per pixel: (d, C, k, -), (d_cull, C_cull, k_cull, -)) of the cull loop.
void draw_cull_depth(Canvas& canvas, const std::vector<glm::vec4>& pixel_state, double near, double far);
void draw_confidence(Canvas& canvas, const std::vector<glm::vec4>& pixel_state, double c_occ);
// Histogram of pixel (x, y): bins counts (stored cumulative, as read_histograms returns) and range.
void draw_histogram(Canvas& canvas, const std::vector<float>& histograms, const std::vector<glm::vec2>& ranges,
                    uint32_t bins, uint32_t x, uint32_t y);

}  // namespace mds::viewer
