// Rays through a rendered frame's pixels, on the CPU; see pixel_rays.h.
#include "render/pixel_rays.h"

#include <algorithm>
#include <cmath>

namespace mds::render {

PixelRays::PixelRays(const Camera& camera, uint32_t width, uint32_t height)
    : view(view_matrix(camera, glm::dvec3(0.0))),
      proj(projection_matrix(camera, double(width) / double(std::max(height, 1u)))),
      inv_proj(glm::inverse(proj)),
      w(width),
      h(height),
      near(camera.near) {}

bool PixelRays::project(const glm::dvec3& v, glm::dvec3& out) const {
  const glm::dvec4 c = proj * glm::dvec4(v, 1.0);
  if (c.w <= 0.0) return false;
  out = glm::dvec3((c.x / c.w * 0.5 + 0.5) * w, (c.y / c.w * 0.5 + 0.5) * h, c.z / c.w);
  return true;
}

void PixelRays::ray(double px, double py, glm::dvec3& o, glm::dvec3& d) const {
  const glm::dvec2 ndc(px / w * 2.0 - 1.0, py / h * 2.0 - 1.0);
  const glm::dvec4 n = inv_proj * glm::dvec4(ndc, 0.0, 1.0), f = inv_proj * glm::dvec4(ndc, 1.0, 1.0);
  o = glm::dvec3(n) / n.w;
  d = glm::normalize(glm::dvec3(f) / f.w - o);
}

double PixelRays::view_distance(double z_ndc) const {
  const glm::dvec4 v = inv_proj * glm::dvec4(0.0, 0.0, z_ndc, 1.0);
  return -v.z / v.w;
}

void view_box(const glm::dmat4& view, const glm::dvec3& lo, const glm::dvec3& hi, glm::dvec3& vlo, glm::dvec3& vhi) {
  vlo = glm::dvec3(1e300);
  vhi = glm::dvec3(-1e300);
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 p((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
    const glm::dvec3 v = glm::dvec3(view * glm::dvec4(p, 1.0));
    vlo = glm::min(vlo, v);
    vhi = glm::max(vhi, v);
  }
}

double ray_sphere_front(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& c, double r) {
  // The perpendicular from c to the ray rather than b^2 - (|oc|^2 - r^2): no cancellation when
  // the sphere is tiny against its distance (1e-3 at 1e4).
  const glm::dvec3 oc = o - c;
  const double b = glm::dot(oc, d);
  const glm::dvec3 perp = oc - b * d;
  const double disc = r * r - glm::dot(perp, perp);
  if (disc < 0.0) return -1.0;
  return -b - std::sqrt(disc);
}

}  // namespace mds::render
