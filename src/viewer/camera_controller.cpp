#include "viewer/camera_controller.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/constants.hpp>

namespace mds::viewer {

namespace {

glm::dvec3 rotate(const glm::dvec3& v, const glm::dvec3& axis, double angle) {
  // Rodrigues' rotation formula (axis normalised).
  const double c = std::cos(angle), s = std::sin(angle);
  return v * c + glm::cross(axis, v) * s + axis * glm::dot(axis, v) * (1.0 - c);
}

double tan_half_fov(const render::Camera& c) { return std::tan(glm::radians(c.fov_y_deg) * 0.5); }

}  // namespace

bool same_camera(const render::Camera& a, const render::Camera& b) {
  return a.eye == b.eye && a.target == b.target && a.up == b.up && a.fov_y_deg == b.fov_y_deg &&
         a.ortho == b.ortho && a.ortho_half_height == b.ortho_half_height && a.near == b.near && a.far == b.far;
}

CameraController::CameraController(const render::Camera& home, const render::Bounds& bounds)
    : camera_(home), home_(home), bounds_(bounds) {}

glm::dvec3 CameraController::forward() const {
  const glm::dvec3 f = camera_.target - camera_.eye;
  const double l = glm::length(f);
  return l > 0 ? f / l : glm::dvec3(0, 0, -1);
}

glm::dvec3 CameraController::right() const {
  glm::dvec3 r = glm::cross(forward(), camera_.up);
  const double l = glm::length(r);
  return l > 1e-12 ? r / l : glm::dvec3(1, 0, 0);
}

double CameraController::distance() const { return glm::length(camera_.target - camera_.eye); }

void CameraController::orbit(double dx, double dy, double viewport_height) {
  const double k = glm::pi<double>() / std::max(viewport_height, 1.0);
  const glm::dvec3 up = glm::normalize(camera_.up);
  glm::dvec3 offset = camera_.eye - camera_.target;
  // Yaw about the up axis (drag right: the scene turns right, the eye moves left).
  offset = rotate(offset, up, -dx * k);
  // Pitch about the right axis, clamped 1 degree short of the poles.
  const double len = glm::length(offset);
  if (len <= 0) return;
  const double elevation = std::asin(std::clamp(glm::dot(offset / len, up), -1.0, 1.0));
  const double limit = glm::radians(89.0);
  const double new_elevation = std::clamp(elevation + dy * k, -limit, limit);
  glm::dvec3 r = glm::cross(-offset, up);
  if (glm::length(r) > 1e-12) offset = rotate(offset, glm::normalize(r), -(new_elevation - elevation));
  camera_.eye = camera_.target + offset;
}

void CameraController::pan(double dx, double dy, double viewport_height) {
  const double half_h = camera_.ortho ? (camera_.ortho_half_height > 0 ? camera_.ortho_half_height
                                                                       : distance() * tan_half_fov(camera_))
                                      : distance() * tan_half_fov(camera_);
  const double per_px = 2.0 * half_h / std::max(viewport_height, 1.0);
  const glm::dvec3 u = glm::normalize(glm::cross(right(), forward()));
  const glm::dvec3 d = (-dx * right() + dy * u) * per_px;
  camera_.eye += d;
  camera_.target += d;
}

void CameraController::zoom(double steps) {
  const double f = std::pow(0.85, steps);
  // Orthographic too: the half height follows the distance (distance * tan(fov / 2)), as the
  // camera path format defines it, so a recorded ortho zoom replays the same.
  camera_.ortho_half_height = 0.0;
  const double min_d = std::max(1e-4 * bounds_.bounding_radius(), 1e-9);
  const double d = std::max(distance() * f, min_d);
  camera_.eye = camera_.target - forward() * d;
}

void CameraController::fly(glm::dvec3 axes, double seconds) {
  const double speed = 0.5 * std::max(bounds_.bounding_radius(), 1e-9);
  const glm::dvec3 u = glm::normalize(glm::cross(right(), forward()));
  const glm::dvec3 d = (axes.x * right() + axes.y * u + axes.z * forward()) * speed * seconds;
  camera_.eye += d;
  camera_.target += d;
}

void CameraController::change_fov(double delta_deg) {
  if (camera_.ortho) {
    // Orthographic: the field of view sets the height at the target (as `render --fov`).
    camera_.ortho_half_height = 0.0;
  }
  camera_.fov_y_deg = std::clamp(camera_.fov_y_deg + delta_deg, 5.0, 150.0);
}

void CameraController::toggle_ortho() {
  camera_.ortho = !camera_.ortho;
  camera_.ortho_half_height = 0.0;  // derived from distance and fov: same apparent size at the target
}

}  // namespace mds::viewer
