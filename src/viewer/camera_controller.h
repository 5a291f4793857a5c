// Interactive camera of the viewer: orbit (around the target), pan (eye and target together, in
// the view plane), zoom (distance to the target), fly (WASD/QE:
// eye and target move along the view axes), field of view and orthographic toggle, reset.
// Pure math on render::Camera (no window), so it is unit-tested directly.
#pragma once

#include <glm/glm.hpp>

#include "render/camera.h"

namespace mds::viewer {

bool same_camera(const render::Camera& a, const render::Camera& b);

class CameraController {
 public:
  CameraController() = default;
  // `home` is the view R returns to; `bounds` scales fly speed and the zoom limits.
  CameraController(const render::Camera& home, const render::Bounds& bounds);

  const render::Camera& camera() const { return camera_; }
  void set(const render::Camera& camera) { camera_ = camera; }
  void reset() { camera_ = home_; }

  // Mouse deltas in pixels; `viewport_height` in pixels. Orbit: a drag over the window height
  // turns by 180 degrees (yaw about the camera's up, pitch about its right axis, never past the pole).
  void orbit(double dx, double dy, double viewport_height);
  // The point under the cursor at the target's depth follows the cursor.
  void pan(double dx, double dy, double viewport_height);
  // Wheel steps (positive: closer). Each step scales the distance to the target by 0.85 (ortho:
  // the half height, distance * tan(fov / 2), with it).
  void zoom(double steps);
  // Moves eye and target by `axes` (right, up, forward) * speed * seconds; speed = half the
  // scene's bounding radius per second.
  void fly(glm::dvec3 axes, double seconds);
  void change_fov(double delta_deg);  // clamped to [5, 150]
  void toggle_ortho();                // keeps the apparent size at the target

  glm::dvec3 forward() const;
  glm::dvec3 right() const;
  double distance() const;

 private:
  render::Camera camera_, home_;
  render::Bounds bounds_;
};

}  // namespace mds::viewer
