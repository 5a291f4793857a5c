// Section codec: a byte-plane transform (the "shuffle" filter of Blosc/HDF5) makes the mostly
// small uint32 voxel deltas, voxel counts and density counts compressible by LZ4: the high-byte
// planes become long runs of zeros. Measurements: docs/results/store-layout.md.
#include "store/section_codec.h"

#include <lz4.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "core/huge_pages.h"

namespace mds::store {

namespace {

// Section buffers are written whole right after allocation: no zero fill. On the 2-core VM a
// zero-filled 8 bytes per voxel ref cost the converter's finish about as much as the LZ4 pass
// itself (fresh pages faulted in by memset). Buffers of 4 MiB and more are 2 MiB-aligned and ask
// for huge pages: the first touch of fresh memory is an expensive fault there, one per 4 KiB
// page otherwise (the voxel and density sections of a 10M store are 7.5 and 4 MB, each with an
// LZ4 scratch of the same size).
struct FreeBytes {
  void operator()(uint8_t* p) const { std::free(p); }
};
using Bytes = std::unique_ptr<uint8_t[], FreeBytes>;

Bytes allocate(size_t n) {
  constexpr size_t kHugeFrom = 2 * kHugePageBytes;
  if (n < kHugeFrom) return Bytes(static_cast<uint8_t*>(std::malloc(std::max<size_t>(n, 1))));
  return Bytes(static_cast<uint8_t*>(allocate_huge_aligned(n)));
}

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

// One LZ4 block of raw[0, n). The bound-sized scratch is touched only as far as LZ4 writes, and
// only the compressed bytes are copied into the result.
Result<std::vector<uint8_t>> compress(const uint8_t* raw, size_t n, const char* what) {
  std::vector<uint8_t> out;
  if (n == 0) return out;
  if (n > size_t(LZ4_MAX_INPUT_SIZE))
    return make_error(Errc::range, "{} of {} bytes exceeds the LZ4 block limit", what, n);
  const int bound = LZ4_compressBound(int(n));
  Bytes scratch = allocate(size_t(bound));
  if (!scratch) return make_error(Errc::range, "cannot allocate {} bytes to compress the {}", bound, what);
  const int c = LZ4_compress_default(reinterpret_cast<const char*>(raw), reinterpret_cast<char*>(scratch.get()),
                                     int(n), bound);
  if (c <= 0) return make_error(Errc::internal, "LZ4 compression of the {} ({} bytes) failed", what, n);
  out.assign(scratch.get(), scratch.get() + c);
  return out;
}

// Decodes the block into raw[0, n); succeeds only when it fills all n bytes.
Status decompress(std::span<const uint8_t> block, uint8_t* raw, size_t n) {
  const int got = LZ4_decompress_safe(reinterpret_cast<const char*>(block.data()), reinterpret_cast<char*>(raw),
                                      int(block.size()), int(n));
  if (got != int(n))
    return make_error(Errc::format, "LZ4 block is corrupt (decoded {} of {} bytes)", got, n);
  return {};
}

}  // namespace

Result<std::vector<uint8_t>> encode_voxel_section(std::span<const VoxelRef> refs) {
  const size_t r = refs.size();
  if (r > kMaxVoxelRefs) return make_error(Errc::range, "{} voxel refs exceed the format's limit of {}", r, kMaxVoxelRefs);
  // Planes 0-3: voxel deltas (mod 2^32), planes 4-7: counts.
  Bytes raw = allocate(8 * r);
  if (!raw) return make_error(Errc::range, "cannot allocate {} bytes for the voxel lists", 8 * r);
  uint8_t* p = raw.get();
  uint32_t prev = 0;
  for (size_t i = 0; i < r; ++i) {
    const uint32_t d = refs[i].voxel - prev, c = refs[i].count;
    prev = refs[i].voxel;
    p[i] = uint8_t(d), p[r + i] = uint8_t(d >> 8), p[2 * r + i] = uint8_t(d >> 16), p[3 * r + i] = uint8_t(d >> 24);
    p[4 * r + i] = uint8_t(c), p[5 * r + i] = uint8_t(c >> 8), p[6 * r + i] = uint8_t(c >> 16),
              p[7 * r + i] = uint8_t(c >> 24);
  }
  return compress(raw.get(), 8 * r, "voxel lists");
}

Status decode_voxel_section(std::span<const uint8_t> block, std::span<VoxelRef> refs) {
  const size_t r = refs.size();
  if (r == 0) return {};
  Bytes raw = allocate(8 * r);
  if (!raw) return make_error(Errc::range, "cannot allocate {} bytes for the voxel lists", 8 * r);
  MDS_TRY(decompress(block, raw.get(), 8 * r));
  uint32_t voxel = 0;
  for (size_t i = 0; i < r; ++i) {
    voxel += from_planes(raw.get(), r, i);
    refs[i].voxel = voxel;
    refs[i].count = from_planes(raw.get() + 4 * r, r, i);
  }
  return {};
}

Result<std::vector<uint8_t>> encode_density_section(std::span<const uint32_t> counts) {
  Bytes raw = allocate(4 * counts.size());
  if (!raw) return make_error(Errc::range, "cannot allocate {} bytes for the density volume", 4 * counts.size());
  to_planes(counts.data(), counts.size(), raw.get());
  return compress(raw.get(), 4 * counts.size(), "density volume");
}

Status decode_density_section(std::span<const uint8_t> block, std::span<uint32_t> counts) {
  const size_t n = counts.size();
  if (n == 0) return {};
  Bytes raw = allocate(4 * n);
  if (!raw) return make_error(Errc::range, "cannot allocate {} bytes for the density volume", 4 * n);
  MDS_TRY(decompress(block, raw.get(), 4 * n));
  for (size_t i = 0; i < n; ++i) counts[i] = from_planes(raw.get(), n, i);
  return {};
}

CellRecord encode_cell(const SimulationCell& cell) {
  CellRecord r{};
  for (int d = 0; d < 3; ++d) {
    r.origin[d] = cell.origin[d];
    for (int k = 0; k < 3; ++k) r.vectors[d][k] = cell.vectors[d][k];
    if (cell.periodic[d]) r.periodic |= 1u << d;
  }
  return r;
}

Result<SimulationCell> decode_cell(const CellRecord& r) {
  SimulationCell c;
  for (int d = 0; d < 3; ++d) {
    if (!std::isfinite(r.origin[d]))
      return make_error(Errc::format, "origin[{}] at byte {} of the record is not finite", d,
                        offsetof(CellRecord, origin) + 8 * d);
    if (std::abs(r.origin[d]) > SimulationCell::kMaxMagnitude)
      return make_error(Errc::format, "origin[{}] at byte {} of the record is {}, beyond {}", d,
                        offsetof(CellRecord, origin) + 8 * d, r.origin[d], SimulationCell::kMaxMagnitude);
    c.origin[d] = r.origin[d];
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(r.vectors[d][k]))
        return make_error(Errc::format, "vectors[{}][{}] at byte {} of the record is not finite", d, k,
                          offsetof(CellRecord, vectors) + 8 * (3 * d + k));
      if (std::abs(r.vectors[d][k]) > SimulationCell::kMaxMagnitude)
        return make_error(Errc::format, "vectors[{}][{}] at byte {} of the record is {}, beyond {}", d, k,
                          offsetof(CellRecord, vectors) + 8 * (3 * d + k), r.vectors[d][k],
                          SimulationCell::kMaxMagnitude);
      c.vectors[d][k] = r.vectors[d][k];
    }
    c.periodic[d] = (r.periodic >> d) & 1u;
  }
  if (r.periodic & ~7u)
    return make_error(Errc::format, "periodic at byte {} of the record has unknown bits {:#x}", offsetof(CellRecord, periodic),
                      r.periodic & ~7u);
  for (int i = 0; i < 7; ++i)
    if (r.reserved[i] != 0)
      return make_error(Errc::format, "reserved at byte {} of the record is not zero", offsetof(CellRecord, reserved) + 4 * i);
  return c;
}

}  // namespace mds::store
