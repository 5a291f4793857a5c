// Node payload codec: quantized positions and type indices of each meshlet stored as offsets
// from the meshlet minimum, bit-packed with per-meshlet, per-axis widths (the layout of
// format.h / docs/store-format.md; the measurements that chose it are in
// docs/results/store-layout.md). Meshlets are the spatially compact groups of paper 000, §6
// ("Meshlet generation"), so their offsets need few bits. Decoding validates everything.
#include "store/payload_codec.h"

#include <algorithm>
#include <bit>
#include <cstring>

namespace mds::store {

namespace {

inline uint16_t load16(const uint8_t* p) {
  uint16_t v;
  std::memcpy(&v, p, 2);
  return v;
}

inline void store16(uint8_t* p, uint16_t v) { std::memcpy(p, &v, 2); }

// Writes little-endian, LSB-first bit fields of <= 16 bits into a buffer sized in advance
// (the caller computed the stream's length from the widths) plus 8 bytes of slack: after each
// field the accumulator is stored as 8 bytes and the pointer advances by its whole bytes, so
// no branch depends on the data (the bytes past the end are rewritten by the next store, or
// trimmed).
class BitWriter {
 public:
  explicit BitWriter(uint8_t* out) : p_(out) {}
  // value < 2^width, width <= 16 (the accumulator holds at most 7 + 16 bits before the store)
  void put(uint32_t value, unsigned width) {
    acc_ |= uint64_t(value) << bits_;
    bits_ += width;
    std::memcpy(p_, &acc_, 8);
    p_ += bits_ >> 3;
    acc_ >>= bits_ & ~7u;
    bits_ &= 7u;
  }
  // Three values of one width (3 x 16 + 7 bits fit the accumulator): one store.
  void put3(uint32_t v0, uint32_t v1, uint32_t v2, unsigned width) {
    const uint64_t chunk = uint64_t(v0) | (uint64_t(v1) << width) | (uint64_t(v2) << (2 * width));
    acc_ |= chunk << bits_;
    bits_ += 3 * width;
    std::memcpy(p_, &acc_, 8);
    p_ += bits_ >> 3;
    acc_ >>= bits_ & ~7u;
    bits_ &= 7u;
  }
  // The last partial byte is already stored (its unused high bits are zero); returns the end.
  uint8_t* flush() { return p_ + (bits_ + 7) / 8; }

 private:
  uint8_t* p_;
  uint64_t acc_ = 0;
  unsigned bits_ = 0;
};

// Reads runs of bit fields of <= 16 bits from a stream whose total length the caller checked
// against the widths, so no field extends past `size` bytes. Runs whose last field ends at
// least 8 bytes before the end read 8 bytes per field without a bounds test.
class BitReader {
 public:
  BitReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  // Calls sink(e, value) for e in [0, count), each value `width` bits wide.
  template <class Sink>
  void run(size_t count, unsigned width, Sink&& sink) {
    const uint64_t mask = (uint64_t(1) << width) - 1;
    uint64_t pos = pos_;
    const uint64_t end = pos + uint64_t(count) * width;
    if ((end >> 3) + 8 <= size_) {
      for (size_t e = 0; e < count; ++e, pos += width) {
        uint64_t word;
        std::memcpy(&word, data_ + (pos >> 3), 8);
        sink(e, uint32_t((word >> (pos & 7)) & mask));
      }
    } else {
      for (size_t e = 0; e < count; ++e, pos += width) {
        const uint64_t byte = pos >> 3;
        uint64_t word = 0;
        std::memcpy(&word, data_ + byte, std::min<uint64_t>(8, size_ - byte));
        sink(e, uint32_t((word >> (pos & 7)) & mask));
      }
    }
    pos_ = end;
  }

 private:
  const uint8_t* data_;
  size_t size_;
  uint64_t pos_ = 0;
};

}  // namespace

void encode_payload(const NodeInput& node, std::vector<uint8_t>& raw) {
  const size_t n = node.type_index.size(), m = node.meshlet_size.size();
  const bool radius = !node.radius_q.empty(), property = !node.property_q.empty(), color = !node.color.empty();
  const uint32_t flags =
      (radius ? kFlagPerParticleRadius : 0u) | (property ? kFlagProperty : 0u) | (color ? kFlagColor : 0u);
  const size_t fixed = node_payload_fixed_bytes(n, m, flags);
  // Large enough for the widest stream and the bit writer's slack; trimmed to the exact size at the end.
  raw.resize(node_payload_max_bytes(n, m, flags) + 8);
  uint8_t* sizes = raw.data();
  uint8_t* base = sizes + m;
  uint8_t* widths = base + 6 * m;
  uint8_t* type_base = widths + 2 * m;
  uint8_t* type_bits = type_base + m;
  std::memcpy(sizes, node.meshlet_size.data(), m);
  if (radius) std::memcpy(type_bits + m, node.radius_q.data(), 2 * n);
  if (property) std::memcpy(type_bits + m + (radius ? 2 * n : 0), node.property_q.data(), 2 * n);
  // Little-endian RGBA bytes (the format's byte order; the hosts mdstream builds for are little-endian).
  if (color) std::memcpy(type_bits + m + (radius ? 2 * n : 0) + (property ? 2 * n : 0), node.color.data(), 4 * n);
  const uint16_t* q = node.qpos.data();
  const uint8_t* t = node.type_index.data();
  BitWriter bw(raw.data() + fixed);
  size_t k0 = 0;
  for (size_t j = 0; j < m; ++j) {
    const size_t end = k0 + node.meshlet_size[j];
    // Bounds in six scalars: with lo[a] and hi[a] the compiler kept the arrays in memory and
    // stored one per coordinate (this loop was the encoder's hottest).
    uint16_t lx = 0xFFFF, ly = 0xFFFF, lz = 0xFFFF, hx = 0, hy = 0, hz = 0;
    for (size_t k = k0; k < end; ++k) {
      lx = std::min(lx, q[3 * k]);
      ly = std::min(ly, q[3 * k + 1]);
      lz = std::min(lz, q[3 * k + 2]);
      hx = std::max(hx, q[3 * k]);
      hy = std::max(hy, q[3 * k + 1]);
      hz = std::max(hz, q[3 * k + 2]);
    }
    const uint16_t lo[3] = {lx, ly, lz}, hi[3] = {hx, hy, hz};
    uint16_t w = 0;
    unsigned wa[3];
    for (int a = 0; a < 3; ++a) {
      store16(base + 2 * (a * m + j), lo[a]);
      wa[a] = unsigned(std::bit_width(unsigned(hi[a] - lo[a])));
      w = uint16_t(w | (wa[a] << (5 * a)));
    }
    store16(widths + 2 * j, w);
    uint8_t tlo = 0xFF, thi = 0;
    for (size_t k = k0; k < end; ++k) {
      tlo = std::min(tlo, t[k]);
      thi = std::max(thi, t[k]);
    }
    const unsigned tw = unsigned(std::bit_width(unsigned(thi - tlo)));
    type_base[j] = tlo;
    type_bits[j] = uint8_t(tw);
    // The meshlet's bit fields: x offsets, y offsets, z offsets, type offsets.
    for (int a = 0; a < 3; ++a) {
      const uint16_t* qa = q + a;
      const uint32_t la = lo[a];
      const unsigned wd = wa[a];
      if (wd == 0) continue;
      size_t k = k0;
      for (; k + 3 <= end; k += 3) bw.put3(qa[3 * k] - la, qa[3 * k + 3] - la, qa[3 * k + 6] - la, wd);
      for (; k < end; ++k) bw.put(qa[3 * k] - la, wd);
    }
    if (tw != 0)
      for (size_t k = k0; k < end; ++k) bw.put(uint32_t(t[k] - tlo), tw);
    k0 = end;
  }
  raw.resize(size_t(bw.flush() - raw.data()));
}

Status decode_payload_raw(std::span<const uint8_t> raw, const PayloadLimits& lim, NodeData& out) {
  const size_t n = lim.particle_count, m = lim.meshlet_count;
  const bool has_radius = (lim.flags & kFlagPerParticleRadius) != 0, has_property = (lim.flags & kFlagProperty) != 0;
  const bool has_color = (lim.flags & kFlagColor) != 0;
  const size_t fixed = node_payload_fixed_bytes(n, m, lim.flags);
  if (raw.size() < fixed)
    return make_error(Errc::format, "decoded payload has {} bytes, fewer than the {} of its fixed arrays", raw.size(), fixed);
  const uint8_t* sizes = raw.data();
  const uint8_t* base = sizes + m;
  const uint8_t* widths = base + 6 * m;
  const uint8_t* type_base = widths + 2 * m;
  const uint8_t* type_bits = type_base + m;
  const uint8_t* radius = type_bits + m;
  const uint8_t* property = radius + (has_radius ? 2 * n : 0);
  const uint8_t* color = property + (has_property ? 2 * n : 0);
  const uint8_t* stream = raw.data() + fixed;
  const size_t stream_bytes = raw.size() - fixed;

  // Meshlet sizes and widths first: they decide how much of the stream is read.
  uint64_t sum = 0, bits = 0;
  for (size_t j = 0; j < m; ++j) {
    if (sizes[j] < 1 || sizes[j] > lim.meshlet_size_max)
      return make_error(Errc::range, "meshlet {} has {} particles (allowed 1..{})", j, sizes[j], lim.meshlet_size_max);
    sum += sizes[j];
    const uint16_t w = load16(widths + 2 * j);
    const unsigned wx = w & 31u, wy = (w >> 5) & 31u, wz = (w >> 10) & 31u;
    if ((w >> 15) != 0 || wx > kMaxAxisBits || wy > kMaxAxisBits || wz > kMaxAxisBits)
      return make_error(Errc::range, "meshlet {} bit widths {:#06x}: x {} y {} z {} (each at most {}, bit 15 zero)", j, w, wx,
                        wy, wz, kMaxAxisBits);
    if (type_bits[j] > kMaxTypeBits)
      return make_error(Errc::range, "meshlet {} type offsets of {} bits (at most {})", j, type_bits[j], kMaxTypeBits);
    bits += uint64_t(sizes[j]) * (wx + wy + wz + type_bits[j]);
  }
  if (sum != n) return make_error(Errc::range, "meshlet sizes sum to {}, node has {} particles", sum, n);
  if ((bits + 7) / 8 != stream_bytes)
    return make_error(Errc::format, "bit stream has {} bytes, the meshlet bit widths give {} bits", stream_bytes, bits);
  if (bits % 8 != 0 && (stream[stream_bytes - 1] >> (bits % 8)) != 0)
    return make_error(Errc::format, "padding bits of the bit stream's last byte are not zero");

  out.meshlet_size.assign(sizes, sizes + m);
  out.qpos.resize(3 * n);
  out.type_index.resize(n);
  if (has_radius) {
    out.radius_q.resize(n);
    std::memcpy(out.radius_q.data(), radius, 2 * n);
  } else {
    out.radius_q.clear();
  }
  if (has_property) {
    out.property_q.resize(n);
    std::memcpy(out.property_q.data(), property, 2 * n);
  } else {
    out.property_q.clear();
  }
  if (has_color) {
    out.color.resize(n);
    std::memcpy(out.color.data(), color, 4 * n);
  } else {
    out.color.clear();
  }
  BitReader br(stream, stream_bytes);
  uint16_t* q = out.qpos.data();
  uint8_t* t = out.type_index.data();
  size_t k0 = 0;
  for (size_t j = 0; j < m; ++j) {
    const size_t c = sizes[j];
    const uint16_t w = load16(widths + 2 * j);
    for (unsigned a = 0; a < 3; ++a) {
      const unsigned wa = (w >> (5 * a)) & 31u;
      const uint32_t b = load16(base + 2 * (a * m + j));
      uint32_t any = 0;
      uint16_t* qa = q + 3 * k0 + a;
      br.run(c, wa, [&](size_t e, uint32_t off) {
        const uint32_t v = b + off;
        any |= v;
        qa[3 * e] = uint16_t(v);
      });
      if (any > kQuantMax)
        return make_error(Errc::range, "meshlet {} axis {}: base {} plus a {}-bit offset exceeds {}", j, "xyz"[a], b, wa,
                          kQuantMax);
    }
    const uint32_t tb = type_base[j];
    const unsigned tw = type_bits[j];
    uint32_t tmax = 0;
    br.run(c, tw, [&](size_t e, uint32_t off) {
      const uint32_t v = tb + off;
      tmax = std::max(tmax, v);
      t[k0 + e] = uint8_t(v);
    });
    if (tmax >= lim.type_count) {  // name the first offending particle: t < tb means tb + offset wrapped past 255
      for (size_t e = 0; e < c; ++e)
        if (t[k0 + e] >= lim.type_count || uint32_t(t[k0 + e]) < tb)
          return make_error(Errc::range, "particle {} has type index {} (type table has {})", k0 + e,
                            t[k0 + e] < tb ? uint32_t(t[k0 + e]) + 256 : uint32_t(t[k0 + e]), lim.type_count);
    }
    k0 += c;
  }
  return {};
}

}  // namespace mds::store
