// Raw float32 xyz reader: round trip, size checks, non-finite values with byte offsets.
#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "binreader_test_util.h"
#include "readers/reader_factories.h"

namespace mds {
namespace {

using testing::TempDir;

std::vector<float> random_xyz(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(-1000.0f, 1000.0f);
  std::vector<float> v(n * 3);
  for (auto& x : v) x = d(rng);
  return v;
}

TEST(RawReader, RoundTripInBatches) {
  TempDir dir;
  for (size_t n : {size_t{0}, size_t{1}, size_t{1000}, size_t{12345}}) {
    const auto v = random_xyz(n, static_cast<uint32_t>(n + 7));
    auto p = dir / "p.raw";
    testing::write_bytes(p, v.data(), v.size() * sizeof(float));
    for (size_t batch : {size_t{1}, size_t{999}, size_t{1} << 22}) {
      if (n > 2000 && batch == 1) continue;
      auto r = open_raw_reader(p, {});
      ASSERT_TRUE(r.ok()) << r.error().message;
      EXPECT_EQ((*r)->info().particle_count, n);
      EXPECT_FALSE((*r)->info().has_box);
      EXPECT_FALSE((*r)->info().has_radius);
      auto all = testing::read_all(**r, batch);
      ASSERT_TRUE(all.ok()) << all.error().message;
      ASSERT_EQ(all->x.size(), n);
      for (size_t i = 0; i < n; ++i) {
        ASSERT_EQ(all->x[i], static_cast<double>(v[3 * i])) << i;
        ASSERT_EQ(all->y[i], static_cast<double>(v[3 * i + 1])) << i;
        ASSERT_EQ(all->z[i], static_cast<double>(v[3 * i + 2])) << i;
        ASSERT_EQ(all->type[i], 1);
      }
      EXPECT_EQ(all->calls, n == 0 ? 0 : (n + batch - 1) / batch);
      ParticleBatch b;
      auto again = (*r)->read(b, 10);  // exhausted stays exhausted
      ASSERT_TRUE(again.ok());
      EXPECT_EQ(*again, 0u);
    }
  }
}

TEST(RawReader, FrameSelection) {
  TempDir dir;
  const auto v = random_xyz(4, 1);
  testing::write_bytes(dir / "a.f32", v.data(), v.size() * 4);
  ReaderOptions o;
  o.frame = -1;
  EXPECT_TRUE(open_raw_reader(dir / "a.f32", o).ok());
  o.frame = 1;
  auto r = open_raw_reader(dir / "a.f32", o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("one frame"), std::string::npos);
}

TEST(RawReader, SizeNotMultipleOf12) {
  TempDir dir;
  const auto v = random_xyz(10, 2);
  testing::write_bytes(dir / "bad.raw", v.data(), 118);
  auto r = open_raw_reader(dir / "bad.raw", {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::format);
  EXPECT_NE(r.error().message.find("bad.raw"), std::string::npos);
  EXPECT_NE(r.error().message.find("size 118 bytes"), std::string::npos) << r.error().message;
  auto missing = open_raw_reader(dir / "missing.raw", {});
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, Errc::io);
}

TEST(RawReader, NonFiniteNamesByteOffset) {
  TempDir dir;
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                    -std::numeric_limits<float>::infinity()}) {
    auto v = random_xyz(3000, 3);
    const size_t particle = 2500, coord = 1;
    v[particle * 3 + coord] = bad;
    testing::write_bytes(dir / "nan.raw", v.data(), v.size() * 4);
    auto r = open_raw_reader(dir / "nan.raw", {});
    ASSERT_TRUE(r.ok());
    auto all = testing::read_all(**r, 1000);
    ASSERT_FALSE(all.ok());
    EXPECT_EQ(all.error().code, Errc::range);
    EXPECT_NE(all.error().message.find(fmt::format("byte offset {}", particle * 12 + coord * 4)), std::string::npos)
        << all.error().message;
    EXPECT_NE(all.error().message.find("particle 2500"), std::string::npos) << all.error().message;
  }
}

}  // namespace
}  // namespace mds
