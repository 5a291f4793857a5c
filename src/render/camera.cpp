#include "render/camera.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

namespace mds::render {

Result<Camera> parse_camera(const std::string& spec) {
  std::vector<double> v;
  std::stringstream ss(spec);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      size_t used = 0;
      double x = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(x)) throw std::invalid_argument(item);
      v.push_back(x);
    } catch (const std::exception&) {
      return make_error(Errc::invalid_argument, "--camera '{}': '{}' is not a finite number", spec, item);
    }
  }
  if (v.size() != 6 && v.size() != 9)
    return make_error(Errc::invalid_argument,
                      "--camera '{}': expected 6 or 9 comma-separated numbers (eye, target[, up]), got {}", spec,
                      v.size());
  Camera c;
  c.eye = {v[0], v[1], v[2]};
  c.target = {v[3], v[4], v[5]};
  if (v.size() == 9) c.up = {v[6], v[7], v[8]};
  glm::dvec3 dir = c.target - c.eye;
  if (glm::length(dir) == 0.0)
    return make_error(Errc::invalid_argument, "--camera '{}': eye and target coincide", spec);
  if (glm::length(glm::cross(dir, c.up)) < 1e-12 * glm::length(dir) * glm::length(c.up))
    return make_error(Errc::invalid_argument, "--camera '{}': up vector is parallel to the view direction", spec);
  return c;
}

namespace {

// Distance from `target` along `dir` (unit, towards the eye) at which all 8 corners of the
// bounds grown by radius_max lie inside the perspective frustum, and the orthographic half
// height that holds them. A corner at lateral (x, y) and depth z (towards the eye) is inside iff
// |x| <= (d - z) tan(fov/2) aspect and |y| <= (d - z) tan(fov/2); the box is convex, so its
// corners suffice.
void fit_box(const Bounds& b, const glm::dvec3& target, const glm::dvec3& dir, const glm::dvec3& up_hint,
             double tan_half, double aspect, double* distance, double* ortho_half_height) {
  const glm::dvec3 right = glm::normalize(glm::cross(up_hint, dir));
  const glm::dvec3 up = glm::cross(dir, right);
  const glm::dvec3 lo = b.min - b.radius_max, hi = b.max + b.radius_max;
  double d = 0.0, hh = 0.0;
  for (int i = 0; i < 8; ++i) {
    glm::dvec3 c((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
    glm::dvec3 v = c - target;
    double x = std::abs(glm::dot(v, right)), y = std::abs(glm::dot(v, up)), z = glm::dot(v, dir);
    d = std::max({d, z + x / (tan_half * aspect), z + y / tan_half});
    hh = std::max({hh, y, x / aspect});
  }
  *distance = d * 1.02;  // 2 % margin
  *ortho_half_height = hh * 1.02;
}

}  // namespace

Result<Camera> default_view(int index, const Bounds& bounds, double fov_y_deg, double aspect) {
  Camera c;
  c.fov_y_deg = fov_y_deg;
  const glm::dvec3 center = bounds.center();
  const double R = std::max(bounds.bounding_radius(), 1e-6);
  const double tan_half = std::tan(glm::radians(fov_y_deg) * 0.5);
  double d = 0.0, hh = 0.0;
  switch (index) {
    case 0: {
      const glm::dvec3 dir(0.0, 0.0, 1.0);
      fit_box(bounds, center, dir, c.up, tan_half, aspect, &d, &hh);
      c.target = center;
      c.eye = center + dir * std::max(d, 1e-6);
      c.ortho_half_height = std::max(hh, 1e-6);
      break;
    }
    case 1: {
      const glm::dvec3 dir = glm::normalize(glm::dvec3(1.0, 1.4, 1.2));
      fit_box(bounds, center, dir, c.up, tan_half, aspect, &d, &hh);
      c.target = center;
      c.eye = center + dir * std::max(d, 1e-6);
      c.ortho_half_height = std::max(hh, 1e-6);
      break;
    }
    case 2: {
      c.target = center + 0.75 * (bounds.max - center);
      c.eye = c.target + glm::normalize(glm::dvec3(1.0, 0.8, 1.2)) * (0.25 * R);
      c.ortho_half_height = 0.25 * R * tan_half;
      break;
    }
    default:
      return make_error(Errc::invalid_argument, "--view {}: expected 0, 1 or 2", index);
  }
  return c;
}

void fit_clip_planes(Camera& camera, const Bounds& bounds) {
  if (camera.near > 0.0 && camera.far > camera.near) return;
  const glm::dvec3 dir = glm::normalize(camera.target - camera.eye);
  const double R = std::max(bounds.bounding_radius(), 1e-6);
  const double zc = glm::dot(bounds.center() - camera.eye, dir);  // view distance of the centre
  double far = zc + R;
  if (far <= 0.0) far = R;  // everything behind the camera: any valid planes
  double near = std::max(zc - R, far * 1e-4);
  camera.far = far * 1.0001;
  camera.near = near * 0.9999;
}

glm::dmat4 view_matrix(const Camera& camera, const glm::dvec3& origin) {
  return glm::lookAtRH(camera.eye - origin, camera.target - origin, camera.up);
}

glm::dmat4 projection_matrix(const Camera& camera, double aspect, glm::dvec2 jitter_ndc) {
  const double n = camera.near, f = camera.far;
  glm::dmat4 p(0.0);  // glm: p[column][row]
  if (camera.ortho) {
    double hh = camera.ortho_half_height > 0.0
                    ? camera.ortho_half_height
                    : glm::length(camera.target - camera.eye) * std::tan(glm::radians(camera.fov_y_deg) * 0.5);
    double hw = hh * aspect;
    p[0][0] = 1.0 / hw;
    p[1][1] = -1.0 / hh;
    p[2][2] = 1.0 / (n - f);
    p[3][2] = n / (n - f);
    p[3][3] = 1.0;
  } else {
    double g = 1.0 / std::tan(glm::radians(camera.fov_y_deg) * 0.5);
    p[0][0] = g / aspect;
    p[1][1] = -g;
    p[2][2] = f / (n - f);
    p[3][2] = n * f / (n - f);
    p[2][3] = -1.0;
  }
  // ndc' = ndc + j  <=>  clip' = clip + j * w: row_i += j_i * row_3, i.e. p[c][i] += j_i * p[c][3].
  for (int col = 0; col < 4; ++col) {
    p[col][0] += jitter_ndc.x * p[col][3];
    p[col][1] += jitter_ndc.y * p[col][3];
  }
  return p;
}

double radical_inverse(uint32_t index, uint32_t base) {
  double inv = 1.0 / base, f = inv, r = 0.0;
  while (index > 0) {
    r += f * (index % base);
    index /= base;
    f *= inv;
  }
  return r;
}

glm::dvec2 halton_jitter(uint32_t sample) {
  if (sample == 0) return glm::dvec2(0.0);
  return {radical_inverse(sample, 2) - 0.5, radical_inverse(sample, 3) - 0.5};
}

bool identical_cameras(const Camera& a, const Camera& b) {
  return a.eye == b.eye && a.target == b.target && a.up == b.up && a.fov_y_deg == b.fov_y_deg &&
         a.ortho == b.ortho && a.ortho_half_height == b.ortho_half_height && a.near == b.near && a.far == b.far;
}

}  // namespace mds::render
