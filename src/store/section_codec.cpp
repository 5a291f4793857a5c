// Section codec: a byte-plane transform (the "shuffle" filter of Blosc/HDF5) makes the mostly
// small uint32 voxel deltas, voxel counts and density counts compressible by LZ4: the high-byte
// planes become long runs of zeros. Measurements: docs/results/store-layout.md.
#include "store/section_codec.h"

#include <lz4.h>

#include <cstring>

namespace mds::store {

namespace {

// planes[b * count + i] = byte b of values[i].
void to_planes(const uint32_t* values, size_t count, uint8_t* planes) {
  for (size_t i = 0; i < count; ++i) {
    const uint32_t v = values[i];
    planes[i] = uint8_t(v);
    planes[count + i] = uint8_t(v >> 8);
    planes[2 * count + i] = uint8_t(v >> 16);
    planes[3 * count + i] = uint8_t(v >> 24);
  }
}

uint32_t from_planes(const uint8_t* planes, size_t count, size_t i) {
  return uint32_t(planes[i]) | uint32_t(planes[count + i]) << 8 | uint32_t(planes[2 * count + i]) << 16 |
         uint32_t(planes[3 * count + i]) << 24;
}

Result<std::vector<uint8_t>> compress(const std::vector<uint8_t>& raw, const char* what) {
  std::vector<uint8_t> out;
  if (raw.empty()) return out;
  if (raw.size() > size_t(LZ4_MAX_INPUT_SIZE))
    return make_error(Errc::range, "{} of {} bytes exceeds the LZ4 block limit", what, raw.size());
  out.resize(size_t(LZ4_compressBound(int(raw.size()))));
  const int c = LZ4_compress_default(reinterpret_cast<const char*>(raw.data()), reinterpret_cast<char*>(out.data()),
                                     int(raw.size()), int(out.size()));
  if (c <= 0) return make_error(Errc::internal, "LZ4 compression of the {} ({} bytes) failed", what, raw.size());
  out.resize(size_t(c));
  return out;
}

Status decompress(std::span<const uint8_t> block, std::vector<uint8_t>& raw) {
  const int got = LZ4_decompress_safe(reinterpret_cast<const char*>(block.data()), reinterpret_cast<char*>(raw.data()),
                                      int(block.size()), int(raw.size()));
  if (got != int(raw.size()))
    return make_error(Errc::format, "LZ4 block is corrupt (decoded {} of {} bytes)", got, raw.size());
  return {};
}

}  // namespace

Result<std::vector<uint8_t>> encode_voxel_section(std::span<const VoxelRef> refs) {
  const size_t r = refs.size();
  if (r > kMaxVoxelRefs) return make_error(Errc::range, "{} voxel refs exceed the format's limit of {}", r, kMaxVoxelRefs);
  std::vector<uint32_t> values(2 * r);
  uint32_t prev = 0;
  for (size_t i = 0; i < r; ++i) {
    values[i] = refs[i].voxel - prev;  // mod 2^32
    prev = refs[i].voxel;
    values[r + i] = refs[i].count;
  }
  std::vector<uint8_t> raw(8 * r);
  to_planes(values.data(), r, raw.data());
  to_planes(values.data() + r, r, raw.data() + 4 * r);
  return compress(raw, "voxel lists");
}

Status decode_voxel_section(std::span<const uint8_t> block, std::span<VoxelRef> refs) {
  const size_t r = refs.size();
  if (r == 0) return {};
  std::vector<uint8_t> raw(8 * r);
  MDS_TRY(decompress(block, raw));
  uint32_t voxel = 0;
  for (size_t i = 0; i < r; ++i) {
    voxel += from_planes(raw.data(), r, i);
    refs[i].voxel = voxel;
    refs[i].count = from_planes(raw.data() + 4 * r, r, i);
  }
  return {};
}

Result<std::vector<uint8_t>> encode_density_section(std::span<const uint32_t> counts) {
  std::vector<uint8_t> raw(4 * counts.size());
  to_planes(counts.data(), counts.size(), raw.data());
  return compress(raw, "density volume");
}

Status decode_density_section(std::span<const uint8_t> block, std::span<uint32_t> counts) {
  const size_t n = counts.size();
  if (n == 0) return {};
  std::vector<uint8_t> raw(4 * n);
  MDS_TRY(decompress(block, raw));
  for (size_t i = 0; i < n; ++i) counts[i] = from_planes(raw.data(), n, i);
  return {};
}

}  // namespace mds::store
