// How far a rendered image is from a reference: the error side of `mdstream bench` (what
// accuracy costs in time). Measured on the linear RGB the renderer accumulates, alpha ignored.
#pragma once

#include <cstdint>

#include "core/result.h"
#include "render/renderer.h"

namespace mds::render {

// The renderer's own tolerance: a pixel differs when a channel is more than 0.1 away (the
// culled-vs-unculled tests allow at most 1 % of the pixels to, test_cull_render.cpp).
inline constexpr float kPixelTolerance = 0.1f;

struct ImageDifference {
  double rmse = 0.0;              // root mean square over the RGB channels of every pixel
  double psnr_db = 0.0;           // 10 log10(1 / mse), peak 1; +infinity for identical images
  double max_abs = 0.0;           // largest channel difference
  uint64_t differing_pixels = 0;  // pixels with a channel more than `tolerance` away
  double differing_fraction = 0.0;
};

// Errc::invalid_argument when the sizes differ or a buffer does not hold width x height RGBA.
Result<ImageDifference> compare_images(const FrameImage& image, const FrameImage& reference,
                                       float tolerance = kPixelTolerance);

}  // namespace mds::render
