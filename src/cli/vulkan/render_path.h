// `mdstream render --path orbit|flythrough|jumps|FILE`: an animation, one image per frame of a
// camera path (docs/camera-path.md), rendered headlessly through one renderer: each frame is a
// converged render of its camera (Renderer::render: culling restarts per view, as in the paper),
// and when streaming the GPU cache stays warm from frame to frame, so a frame reads only the
// nodes the previous ones did not leave resident.
#pragma once

#include <cstdint>
#include <string>

#include "core/result.h"
#include "overlay/color_legend.h"
#include "overlay/image_panels.h"
#include "render/camera.h"
#include "render/camera_path.h"
#include "render/renderer.h"

namespace mds::cli {

// The output name of frame `frame`: `pattern` with its one printf conversion %d or %0Nd
// (N 1..9) replaced by the frame number ("out/frame_%04d.png", 7 -> "out/frame_0007.png").
// Errc::invalid_argument when the pattern has no such conversion, more than one, or another '%';
// the message names `option`, the command-line option the pattern came from.
Result<std::string> frame_file_name(const std::string& pattern, uint32_t frame, const char* option = "-o");

struct PathRenderOptions {
  std::string output_pattern;  // -o with %d
  std::string stats;           // --stats JSON ("" = none)
  bool streaming = false;
  uint64_t max_storage_range = 0;  // the device's, for cache_warnings
  overlay::ImagePanels panels;  // --color-legend, --label-corner, --axes: drawn into every frame (the tripod with its camera)
  std::string label_pattern;    // --label ("" = none): expanded per frame with label_fields, {frame} the frame's number
  overlay::LabelFields label_fields;
  bool transparent = false;  // --background transparent: PNG frames with alpha
};

// Renders every frame of `path` with `renderer` and writes frame_file_name(pattern, f) for each;
// one line per frame on stderr; the stats JSON lists the frames (file, wall time, culling,
// bytes read so far). Precondition: !path.empty().
Status render_path(render::Renderer& renderer, const render::CameraPath& path, const PathRenderOptions& o);

}  // namespace mds::cli
