// Camera paths: keyframes in a text file (written by `mdstream view --record`, read by
// `mdstream view --play` and `mdstream stress --path FILE`) and the built-in paths of the
// cache stress tests (orbit, flythrough, jumps), all sampled per frame.
//
// File format (docs/camera-path.md), UTF-8 text, one keyframe per line:
//   # mdstream camera path v1
//   # frame ex ey ez tx ty tz ux uy uz fov_y_deg ortho
//   0 10 10 40 10 10 10 0 1 0 40 0
//   120 40 10 10 10 10 10 0 1 0 40 0
// '#' starts a comment; blank lines are skipped; the first non-comment line must be a keyframe.
// Frames are non-negative integers, strictly increasing. Between keyframes, eye/target/up/fov
// are interpolated linearly (up renormalised); a frame past the last keyframe holds it.
// Errors name the file and line.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "render/camera.h"

namespace mds::render {

struct CameraKey {
  uint32_t frame = 0;
  Camera camera;  // near/far are not stored (0: fitted per frame)
};

class CameraPath {
 public:
  CameraPath() = default;
  explicit CameraPath(std::vector<CameraKey> keys);  // precondition: frames strictly increasing

  static Result<CameraPath> load(const std::filesystem::path& path);
  static Result<CameraPath> parse(std::string_view text, std::string_view name = "<text>");
  // Writes atomically (temporary file + rename).
  Status save(const std::filesystem::path& path) const;
  std::string to_text() const;

  bool empty() const { return keys_.empty(); }
  const std::vector<CameraKey>& keys() const { return keys_; }
  // Last keyframe's frame + 1 (0 when empty).
  uint32_t frame_count() const;
  // The camera at `frame` (interpolated). Precondition: !empty().
  Camera at(uint32_t frame) const;

 private:
  std::vector<CameraKey> keys_;
};

// Built-in paths over `frames` frames around/through the scene bounds (aspect = width / height):
//   orbit       a full circle around the centre at the distance of default view 0, slightly above;
//   flythrough  a straight flight from outside one face through the centre and out the other side,
//               looking ahead (the close-up regime: nodes enter and leave the frustum all the time);
//   jumps       a cut every frames/8 frames between 8 fixed views (default views 0..2 and views
//               from the 6 axis directions) - no coherence between consecutive views.
enum class BuiltinPath { orbit, flythrough, jumps };
Result<BuiltinPath> parse_builtin_path(std::string_view name);  // "orbit" | "flythrough" | "jumps"
CameraPath builtin_path(BuiltinPath kind, const Bounds& bounds, uint32_t frames, double fov_y_deg, double aspect);
const char* builtin_path_name(BuiltinPath kind);
// The 8 views of the jumps path: default views 0..2, then from +x, -x, +y, -y, -z (view 0 is
// the +z one) at the distance where the bounding sphere fits, all looking at the centre.
std::vector<Camera> jump_views(const Bounds& bounds, double fov_y_deg, double aspect);


}  // namespace mds::render
