#include "render/image_io.h"

#include <png.h>
#include <tinyexr.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "render/scene.h"

namespace mds::render {

namespace {

std::filesystem::path temp_path(const std::filesystem::path& path) {
  return path.string() + ".tmp." + std::to_string(::getpid());
}

Status commit(const std::filesystem::path& tmp, const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return make_error(Errc::io, "{}: cannot rename temporary file into place", path.string());
  }
  return {};
}

}  // namespace

Status write_png(const std::filesystem::path& path, const FrameImage& image, bool alpha) {
  const auto tmp = temp_path(path);
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(tmp.c_str(), "wb"), &std::fclose);
  if (!f) return make_error(Errc::io, "{}: cannot open for writing", tmp.string());
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    std::filesystem::remove(tmp);
    return make_error(Errc::internal, "{}: libpng initialisation failed", path.string());
  }
  const size_t channels = alpha ? 4 : 3;
  std::vector<uint8_t> row(size_t(image.width) * channels);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    f.reset();
    std::filesystem::remove(tmp);
    return make_error(Errc::io, "{}: libpng write failed", path.string());
  }
  png_init_io(png, f.get());
  png_set_IHDR(png, info, image.width, image.height, 8, alpha ? PNG_COLOR_TYPE_RGB_ALPHA : PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  for (uint32_t y = 0; y < image.height; ++y) {
    const float* src = &image.rgba[size_t(y) * image.width * 4];
    for (uint32_t x = 0; x < image.width; ++x) {
      const float a = std::clamp(src[4 * x + 3], 0.0f, 1.0f);
      // Straight colour: the premultiplied one over the alpha (none where nothing was met).
      const float inv = alpha ? (a > 0.0f ? 1.0f / a : 0.0f) : 1.0f;
      for (size_t c = 0; c < 3; ++c)
        row[channels * x + c] = uint8_t(std::lround(linear_to_srgb(src[4 * x + c] * inv) * 255.0f));
      if (alpha) row[channels * x + 3] = uint8_t(std::lround(a * 255.0f));
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fflush(f.get()) != 0 || std::fclose(f.release()) != 0) {
    std::filesystem::remove(tmp);
    return make_error(Errc::io, "{}: write failed", tmp.string());
  }
  return commit(tmp, path);
}

Status write_exr(const std::filesystem::path& path, const FrameImage& image) {
  const auto tmp = temp_path(path);
  const char* err = nullptr;
  int r = SaveEXR(image.rgba.data(), int(image.width), int(image.height), 4, 0, tmp.c_str(), &err);
  if (r != TINYEXR_SUCCESS) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    return make_error(Errc::io, "{}: EXR write failed: {}", path.string(), msg);
  }
  return commit(tmp, path);
}

Status write_image(const std::filesystem::path& path, const FrameImage& image, bool alpha) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".exr" ? write_exr(path, image) : write_png(path, image, alpha);
}

}  // namespace mds::render
