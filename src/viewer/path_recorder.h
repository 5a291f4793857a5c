// --record: the session's camera as a camera path (render/camera_path.h), one keyframe per
// displayed frame where the camera changed. When the camera moves again after resting, the
// resting camera is keyed at the frame before, so linear interpolation between keys replays
// the rest as a rest (and not as a slow drift).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "render/camera.h"
#include "render/camera_path.h"

namespace mds::viewer {

class PathRecorder {
 public:
  // Called once per displayed frame, frames increasing.
  void observe(uint32_t frame, const render::Camera& camera);
  render::CameraPath path() const { return render::CameraPath(keys_); }
  size_t key_count() const { return keys_.size(); }

 private:
  std::vector<render::CameraKey> keys_;
  std::optional<render::Camera> last_;
  uint32_t last_frame_ = 0;
};

}  // namespace mds::viewer
