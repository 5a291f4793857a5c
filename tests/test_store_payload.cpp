// Node payload codec (src/store/payload_codec.h): encode_node -> LZ4 -> decode_payload_raw must
// reproduce every quantized coordinate, type index, radius and meshlet size exactly, for
// adversarial coordinate patterns on each axis (all 0, all 65535, alternating extremes,
// alternating around the middle, random, single-bit walks) and meshlet/type extremes.
#include <gtest/gtest.h>

#include <lz4.h>

#include <random>
#include <string>
#include <vector>

#include "store/format.h"
#include "store/payload_codec.h"
#include "store/store_reader.h"
#include "store/store_writer.h"

using namespace mds;
using namespace mds::store;

namespace {

enum class Pattern { zeros, max, alternate_extremes, alternate_middle, random, bit_walk, ramp };
const Pattern kPatterns[] = {Pattern::zeros,  Pattern::max,      Pattern::alternate_extremes, Pattern::alternate_middle,
                             Pattern::random, Pattern::bit_walk, Pattern::ramp};

uint16_t value(Pattern p, size_t k, std::mt19937_64& rng) {
  switch (p) {
    case Pattern::zeros: return 0;
    case Pattern::max: return 65535;
    case Pattern::alternate_extremes: return k % 2 ? 65535 : 0;
    case Pattern::alternate_middle: return k % 2 ? 32768 : 32767;
    case Pattern::random: return uint16_t(rng());
    case Pattern::bit_walk: return uint16_t(1u << (k % 16));
    case Pattern::ramp: return uint16_t(k * 257);
  }
  return 0;
}

struct Case {
  std::vector<uint16_t> qpos;
  std::vector<uint8_t> types;
  std::vector<uint16_t> radius;
  std::vector<uint8_t> meshlets;
};

// Encodes with the writer's encode_node, decompresses the real LZ4 block, decodes and compares.
void expect_exact(const Case& c, uint32_t type_count, uint32_t meshlet_size_max, const std::string& what) {
  NodeInput in;
  in.qpos = c.qpos;
  in.type_index = c.types;
  in.radius_q = c.radius;
  in.meshlet_size = c.meshlets;
  for (int a = 0; a < 3; ++a) {
    in.center_min[a] = 0;
    in.center_max[a] = 1;
  }
  in.max_radius = 1;
  auto enc = encode_node(in);
  ASSERT_TRUE(enc.ok()) << what << ": " << enc.error().message;
  const NodeEntry& e = enc->entry;
  const size_t n = c.types.size(), m = c.meshlets.size();
  const bool radius = !c.radius.empty();
  EXPECT_GE(e.payload_raw_bytes, node_payload_fixed_bytes(n, m, radius)) << what;
  EXPECT_LE(e.payload_raw_bytes, node_payload_max_bytes(n, m, radius)) << what;
  EXPECT_EQ(enc->per_particle_radius, radius) << what;
  std::vector<uint8_t> raw(e.payload_raw_bytes);
  const int got = LZ4_decompress_safe(reinterpret_cast<const char*>(enc->payload.data()), reinterpret_cast<char*>(raw.data()),
                                      int(enc->payload.size()), int(raw.size()));
  ASSERT_EQ(got, int(raw.size())) << what;
  NodeData d;
  Status st = decode_payload_raw(raw, {uint32_t(n), uint32_t(m), radius, type_count, meshlet_size_max}, d);
  ASSERT_TRUE(st.ok()) << what << ": " << st.error().message;
  EXPECT_EQ(d.qpos, c.qpos) << what;
  EXPECT_EQ(d.type_index, c.types) << what;
  EXPECT_EQ(d.radius_q, c.radius) << what;
  EXPECT_EQ(d.meshlet_size, c.meshlets) << what;
}

std::vector<uint8_t> meshlets_of(size_t n, size_t size) {
  std::vector<uint8_t> ms;
  for (size_t k = 0; k < n; k += size) ms.push_back(uint8_t(std::min(size, n - k)));
  return ms;
}

TEST(StorePayload, AdversarialCoordinatesPerAxisRoundTripExactly) {
  const size_t n = 1000;
  for (int axis = 0; axis < 3; ++axis)
    for (Pattern p : kPatterns)
      for (size_t msize : {size_t(1), size_t(16), size_t(255)}) {
        std::mt19937_64 rng(1000 * axis + 10 * int(p) + msize);
        Case c;
        c.qpos.resize(3 * n);
        for (size_t k = 0; k < n; ++k)
          for (int a = 0; a < 3; ++a) c.qpos[3 * k + a] = a == axis ? value(p, k, rng) : uint16_t(rng());
        c.types.assign(n, 0);
        c.meshlets = meshlets_of(n, msize);
        expect_exact(c, 1, 255,
                     "axis " + std::to_string(axis) + " pattern " + std::to_string(int(p)) + " meshlet " +
                         std::to_string(msize));
      }
}

TEST(StorePayload, SamePatternOnAllAxesWithRadiiAndTypes) {
  const size_t n = 777;  // odd: partial last meshlet, unaligned bit stream
  for (Pattern p : kPatterns) {
    std::mt19937_64 rng{uint64_t(p)};
    Case c;
    for (size_t k = 0; k < n; ++k)
      for (int a = 0; a < 3; ++a) c.qpos.push_back(value(p, k + a, rng));
    for (size_t k = 0; k < n; ++k) {
      c.types.push_back(uint8_t(p == Pattern::zeros ? 0 : p == Pattern::max ? 255 : rng()));
      c.radius.push_back(value(p, k, rng));
    }
    c.meshlets = meshlets_of(n, 16);
    expect_exact(c, 256, 16, "pattern " + std::to_string(int(p)));
  }
}

TEST(StorePayload, LargestNodeAndIrregularMeshlets) {
  std::mt19937_64 rng(5);
  Case c;
  size_t n = 0;
  while (n < kMaxNodeParticles) {
    size_t s = std::min<size_t>(1 + rng() % 255, kMaxNodeParticles - n);
    c.meshlets.push_back(uint8_t(s));
    n += s;
  }
  for (size_t k = 0; k < n; ++k) {
    // Spatially coherent like real meshlets, with the occasional full-range outlier.
    for (int a = 0; a < 3; ++a) c.qpos.push_back(rng() % 97 == 0 ? uint16_t(rng()) : uint16_t(20000 + (k * 13 + a * 7) % 3000));
    c.types.push_back(uint8_t(k / 1000 % 4));
  }
  expect_exact(c, 4, 255, "65535 particles");
}

TEST(StorePayload, DecodeRejectsTypeIndexAtTheTableSize) {
  Case c;
  c.qpos.assign(3 * 20, 7);
  for (int k = 0; k < 20; ++k) c.types.push_back(uint8_t(k % 3));
  c.meshlets = meshlets_of(20, 8);
  NodeInput in;
  in.qpos = c.qpos;
  in.type_index = c.types;
  in.meshlet_size = c.meshlets;
  std::vector<uint8_t> raw;
  encode_payload(in, raw);
  NodeData d;
  EXPECT_TRUE(decode_payload_raw(raw, {20, 3, false, 3, 8}, d).ok());
  Status st = decode_payload_raw(raw, {20, 3, false, 2, 8}, d);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, Errc::range);
  EXPECT_NE(st.error().message.find("particle 2 has type index 2 (type table has 2)"), std::string::npos) << st.error().message;
  st = decode_payload_raw(raw, {20, 3, false, 3, 7}, d);  // meshlets of 8 > meshlet_size_max 7
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("meshlet 0 has 8 particles (allowed 1..7)"), std::string::npos) << st.error().message;
  st = decode_payload_raw(std::span<const uint8_t>(raw).first(10), {20, 3, false, 3, 8}, d);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, Errc::format);
}

}  // namespace
