// Camera model and the projection conventions of the renderer (Vulkan): right-handed view space,
// camera looking along -z, NDC y pointing down, depth 0 (near) .. 1 (far).
//   perspective: x_ndc = (f/aspect) x / -z, y_ndc = -f y / -z, f = 1/tan(fov_y/2),
//                z_ndc = far/(far-near) * (1 - near / -z)
//   orthographic (half height h, half width h*aspect): x_ndc = x/(h aspect), y_ndc = -y/h,
//                z_ndc = (-z - near)/(far - near)
// Matrices are built in double and relative to the scene origin (the GPU stores positions as
// floats relative to it). Sub-pixel jitter (progressive super-sampling) is a translation of NDC
// applied after the projection, so the rasterizer and the fragment ray both see it.
#pragma once

#include <cstdint>
#include <string>

#include <glm/glm.hpp>

#include "core/result.h"

namespace mds::render {

struct Bounds {
  glm::dvec3 min{0.0};
  glm::dvec3 max{0.0};
  double radius_max = 0.0;  // largest particle radius (spheres reach this far beyond the centres)
  glm::dvec3 center() const { return 0.5 * (min + max); }
  // Radius of a sphere around center() containing every particle sphere.
  double bounding_radius() const { return 0.5 * glm::length(max - min) + radius_max; }
};

struct Camera {
  glm::dvec3 eye{0.0, 0.0, 1.0};
  glm::dvec3 target{0.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  double fov_y_deg = 40.0;
  bool ortho = false;
  double ortho_half_height = 0.0;  // 0: distance(eye, target) * tan(fov_y / 2)
  double near = 0.0;               // 0 (either plane): fitted to the bounds by fit_clip_planes()
  double far = 0.0;
};

// "ex,ey,ez,tx,ty,tz[,ux,uy,uz]" -> eye, target (and up).
Result<Camera> parse_camera(const std::string& spec);

// Three default views derived from the bounds (aspect = width / height):
//   0  front: looking along -z at the centre, as close as the whole bounds box (grown by the
//      largest radius) stays in view;
//   1  oblique top: from direction (1, 1.4, 1.2) (above, front-right), the whole box in view;
//   2  close-up corner: target 3/4 of the way from the centre to the max corner, eye at a
//      quarter of the bounding radius from it along (1, 0.8, 1.2) -- a view into the data.
Result<Camera> default_view(int index, const Bounds& bounds, double fov_y_deg, double aspect);

// Sets near/far (when either is 0) to enclose the bounds: far = distance to the farthest point
// of the bounding sphere, near = max(distance to its nearest point, far * 1e-4).
void fit_clip_planes(Camera& camera, const Bounds& bounds);

// Exact equality of every field (a "view" of the stress tests is a run of frames with the same camera).
bool identical_cameras(const Camera& a, const Camera& b);

glm::dmat4 view_matrix(const Camera& camera, const glm::dvec3& origin);
// jitter_ndc: NDC offset added after projection (2 * pixel offset / size).
glm::dmat4 projection_matrix(const Camera& camera, double aspect, glm::dvec2 jitter_ndc = glm::dvec2(0.0));

// Halton(2, 3) sub-pixel offset in pixels for sample s, in [-0.5, 0.5)^2; sample 0 is (0, 0)
// (the pixel centre), so a single-sample render is unjittered.
glm::dvec2 halton_jitter(uint32_t sample);
double radical_inverse(uint32_t index, uint32_t base);

}  // namespace mds::render
