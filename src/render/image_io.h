// Writing rendered images: 8-bit sRGB PNG (libpng) or 32-bit float linear RGBA OpenEXR
// (tinyexr) when the name ends in ".exr". Written to "<path>.tmp.<pid>" then renamed, so a
// failed write leaves no partial file.
#pragma once

#include <filesystem>

#include "core/result.h"
#include "render/renderer.h"

namespace mds::render {

Status write_png(const std::filesystem::path& path, const FrameImage& image);
Status write_exr(const std::filesystem::path& path, const FrameImage& image);
// Picks the format from the extension (.exr -> EXR, else PNG).
Status write_image(const std::filesystem::path& path, const FrameImage& image);

}  // namespace mds::render
