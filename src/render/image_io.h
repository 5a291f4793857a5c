// Writing rendered images: 8-bit sRGB PNG (libpng) or 32-bit float linear RGBA OpenEXR
// (tinyexr) when the name ends in ".exr". Written to "<path>.tmp.<pid>" then renamed, so a
// failed write leaves no partial file.
//
// A FrameImage's rgba is the average of its samples: colour composed over the background, alpha
// the share of samples that met a particle (or the cell). With a transparent background (`render
// --background transparent`) the background is black, so the colour is premultiplied by alpha:
// the EXR is written as it is (OpenEXR's convention is premultiplied), the PNG as RGBA with
// straight alpha (colour / alpha, then sRGB; PNG's convention), so that composing it over any
// background gives the render over that background to within 8-bit rounding.
#pragma once

#include <filesystem>

#include "core/result.h"
#include "render/renderer.h"

namespace mds::render {

// RGB, or with `alpha` RGBA with straight alpha (precondition: image over a black background).
Status write_png(const std::filesystem::path& path, const FrameImage& image, bool alpha = false);
Status write_exr(const std::filesystem::path& path, const FrameImage& image);
// Picks the format from the extension (.exr -> EXR, else PNG; `alpha` for write_png).
Status write_image(const std::filesystem::path& path, const FrameImage& image, bool alpha = false);

}  // namespace mds::render
