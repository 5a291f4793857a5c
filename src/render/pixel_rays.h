// The CPU's view of a rendered frame, in double: pixel <-> view space under the renderer's camera
// conventions (camera.h), the ray through a point of the image and its first hit on a sphere.
// Shared by the visible-set reference (visible_nodes.h) and picking (pick.h), so that both ask
// the same questions of the same rays as the renderer's ray test (sprite_raster.h) does.
#pragma once

#include <cstdint>

#include <glm/glm.hpp>

#include "render/camera.h"

namespace mds::render {

struct PixelRays {
  // camera: near/far set (fit_clip_planes); width, height > 0. Matrices relative to the world
  // origin (the CPU works in double, not relative to a scene origin as the GPU does).
  PixelRays(const Camera& camera, uint32_t width, uint32_t height);

  glm::dmat4 view, proj, inv_proj;
  uint32_t w = 0, h = 0;
  double near = 0.0;  // the camera's near plane (view distance)

  // Pixel coordinates (x right, y down, pixel centres at +0.5) and z_ndc of a view-space point;
  // false behind the eye.
  bool project(const glm::dvec3& v, glm::dvec3& out) const;
  // The view-space ray through a screen point (pixel coordinates): origin on the near plane,
  // unit direction.
  void ray(double px, double py, glm::dvec3& o, glm::dvec3& d) const;
  // View distance (-z in view space) of a z_ndc value: it depends on z alone (perspective and
  // orthographic projections).
  double view_distance(double z_ndc) const;
};

// View-space box of a world-space box under the view matrix (its 8 corners).
void view_box(const glm::dmat4& view, const glm::dvec3& lo, const glm::dvec3& hi, glm::dvec3& vlo, glm::dvec3& vhi);

// Distance along the ray (origin o, unit direction d) to the front surface of the sphere (centre
// c, radius r): the smaller root of |o + t d - c| = r. Negative when the ray misses the sphere or
// its front surface lies behind the origin (for a ray from the near plane: in front of it).
double ray_sphere_front(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& c, double r);

// A sphere (view-space centre c, radius r) wholly on the eye's side of the near plane: the
// renderer draws nothing of it (sprite_make.h).
inline bool before_near_plane(const glm::dvec3& c, double r, double near) { return c.z - r >= -near; }

}  // namespace mds::render
