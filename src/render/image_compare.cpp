// Image error against a reference (see image_compare.h).
#include "render/image_compare.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mds::render {

Result<ImageDifference> compare_images(const FrameImage& image, const FrameImage& reference, float tolerance) {
  if (image.width != reference.width || image.height != reference.height)
    return make_error(Errc::invalid_argument, "images of {}x{} and {}x{} pixels cannot be compared", image.width,
                      image.height, reference.width, reference.height);
  const size_t pixels = size_t(image.width) * image.height;
  if (image.rgba.size() != 4 * pixels || reference.rgba.size() != 4 * pixels)
    return make_error(Errc::invalid_argument, "image buffers of {} and {} floats for {} pixels", image.rgba.size(),
                      reference.rgba.size(), pixels);
  ImageDifference d;
  double sum = 0.0;
  for (size_t p = 0; p < pixels; ++p) {
    bool differs = false;
    for (int c = 0; c < 3; ++c) {
      const double e = std::abs(double(image.rgba[4 * p + c]) - double(reference.rgba[4 * p + c]));
      sum += e * e;
      d.max_abs = std::max(d.max_abs, e);
      differs = differs || e > double(tolerance);
    }
    d.differing_pixels += differs ? 1 : 0;
  }
  const double mse = pixels ? sum / double(3 * pixels) : 0.0;
  d.rmse = std::sqrt(mse);
  d.psnr_db = mse > 0.0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
  d.differing_fraction = pixels ? double(d.differing_pixels) / double(pixels) : 0.0;
  return d;
}

}  // namespace mds::render
