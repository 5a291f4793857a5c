// render/image_compare.h, the error side of `mdstream bench`: RMSE, PSNR, largest difference and
// the pixels beyond the renderer's tolerance, on small images whose answers are known.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "render/image_compare.h"

namespace {

mds::render::FrameImage flat(uint32_t w, uint32_t h, float v) {
  mds::render::FrameImage img;
  img.width = w;
  img.height = h;
  img.rgba.assign(size_t(4) * w * h, v);
  return img;
}

TEST(ImageCompare, IdenticalImagesHaveNoError) {
  const auto a = flat(5, 3, 0.25f);
  const auto d = mds::render::compare_images(a, a);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->rmse, 0.0);
  EXPECT_EQ(d->max_abs, 0.0);
  EXPECT_EQ(d->differing_pixels, 0u);
  EXPECT_TRUE(std::isinf(d->psnr_db) && d->psnr_db > 0);
}

TEST(ImageCompare, OnePixelOffByHalf) {
  const auto ref = flat(4, 4, 0.5f);
  auto img = ref;
  img.rgba[4 * 6 + 1] = 1.0f;   // pixel 6, green: 0.5 away
  img.rgba[4 * 9 + 3] = 0.0f;   // alpha is not compared
  img.rgba[4 * 2 + 0] = 0.55f;  // pixel 2, red: 0.05 away, within the 0.1 tolerance
  const auto d = mds::render::compare_images(img, ref);
  ASSERT_TRUE(d.ok());
  const double mse = (0.25 + 0.05 * 0.05) / (3.0 * 16.0);
  EXPECT_NEAR(d->rmse, std::sqrt(mse), 1e-7);
  EXPECT_NEAR(d->psnr_db, 10.0 * std::log10(1.0 / mse), 1e-5);
  EXPECT_NEAR(d->max_abs, 0.5, 1e-7);
  EXPECT_EQ(d->differing_pixels, 1u);
  EXPECT_DOUBLE_EQ(d->differing_fraction, 1.0 / 16.0);
  // A tighter tolerance counts the small difference too.
  EXPECT_EQ(mds::render::compare_images(img, ref, 0.01f)->differing_pixels, 2u);
}

TEST(ImageCompare, MismatchedImagesAreAnError) {
  EXPECT_FALSE(mds::render::compare_images(flat(4, 4, 0), flat(4, 5, 0)).ok());
  auto short_buffer = flat(4, 4, 0);
  short_buffer.rgba.pop_back();
  EXPECT_FALSE(mds::render::compare_images(short_buffer, flat(4, 4, 0)).ok());
}

}  // namespace
