#include "viewer/path_recorder.h"

#include "viewer/camera_controller.h"

namespace mds::viewer {

void PathRecorder::observe(uint32_t frame, const render::Camera& camera_in) {
  render::Camera camera = camera_in;
  camera.near = camera.far = 0.0;  // not stored: fitted per frame
  if (!last_) {
    keys_.push_back({frame, camera});
  } else if (!same_camera(*last_, camera)) {
    if (keys_.back().frame + 1 < frame && frame > 0) keys_.push_back({frame - 1, *last_});
    keys_.push_back({frame, camera});
  }
  last_ = camera;
  last_frame_ = frame;
}

}  // namespace mds::viewer
