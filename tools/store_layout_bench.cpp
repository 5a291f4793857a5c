// Store layout experiment (docs/results/store-layout.md): reads real stores with the real
// StoreReader, times read_node / decode_payload of the implemented layout, then re-encodes
// every node under candidate payload layouts (LZ4_compress_default each) and reports payload
// bytes/particle and decode throughput (LZ4_decompress_safe + inverse transform, best of 5,
// MB/s of decoded NodeData = 7n + m bytes per node), and the voxel/density section variants.
// Built as build/tools/store_layout_bench; run: store_layout_bench STORE.mds [STORE.mds ...]
#include <lz4.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "store/store_reader.h"

using namespace mds;
using namespace mds::store;

struct Node {
  std::vector<uint16_t> q;
  std::vector<uint8_t> t;
  std::vector<uint8_t> ms;
  std::vector<VoxelRef> vox;
};

static std::vector<uint8_t> lz4(const std::vector<uint8_t>& raw) {
  std::vector<uint8_t> c(LZ4_compressBound(int(raw.size())));
  int k = LZ4_compress_default((const char*)raw.data(), (char*)c.data(), int(raw.size()), int(c.size()));
  c.resize(k);
  return c;
}

static inline uint16_t zz(int32_t d) { return uint16_t((uint32_t(d) << 1) ^ uint32_t(d >> 31)); }
static inline int32_t unzz(uint16_t z) { return int32_t(z >> 1) ^ -int32_t(z & 1); }

struct BitWriter {
  std::vector<uint8_t>& out;
  uint64_t acc = 0;
  int bits = 0;
  void put(uint32_t v, int w) {
    acc |= uint64_t(v) << bits;
    bits += w;
    while (bits >= 8) {
      out.push_back(uint8_t(acc));
      acc >>= 8;
      bits -= 8;
    }
  }
  void flush() {
    if (bits > 0) out.push_back(uint8_t(acc));
    acc = 0;
    bits = 0;
  }
};

// ---------------------------------------------------------------- layouts
struct Layout {
  const char* name;
  void (*enc)(const Node&, std::vector<uint8_t>&);
  void (*dec)(const uint8_t* raw, size_t rawn, size_t n, size_t m, Node&);
};

// P0: interleaved xyz, types, meshlets
static void enc0(const Node& nd, std::vector<uint8_t>& r) {
  size_t n = nd.t.size();
  r.resize(6 * n);
  std::memcpy(r.data(), nd.q.data(), 6 * n);
  r.insert(r.end(), nd.t.begin(), nd.t.end());
  r.insert(r.end(), nd.ms.begin(), nd.ms.end());
}
static void dec0(const uint8_t* p, size_t, size_t n, size_t m, Node& o) {
  o.q.resize(3 * n);
  std::memcpy(o.q.data(), p, 6 * n);
  o.t.assign(p + 6 * n, p + 7 * n);
  o.ms.assign(p + 7 * n, p + 7 * n + m);
}

// P1: byte planes hi(x,y,z) lo(x,y,z)
static void enc1(const Node& nd, std::vector<uint8_t>& r) {
  size_t n = nd.t.size();
  r.assign(6 * n, 0);
  for (size_t k = 0; k < n; ++k)
    for (int a = 0; a < 3; ++a) {
      r[a * n + k] = uint8_t(nd.q[3 * k + a] >> 8);
      r[(3 + a) * n + k] = uint8_t(nd.q[3 * k + a]);
    }
  r.insert(r.end(), nd.t.begin(), nd.t.end());
  r.insert(r.end(), nd.ms.begin(), nd.ms.end());
}
static void dec1(const uint8_t* p, size_t, size_t n, size_t m, Node& o) {
  o.q.resize(3 * n);
  for (int a = 0; a < 3; ++a) {
    const uint8_t* hi = p + a * n;
    const uint8_t* lo = p + (3 + a) * n;
    uint16_t* q = o.q.data() + a;
    for (size_t k = 0; k < n; ++k) q[3 * k] = uint16_t(hi[k] << 8 | lo[k]);
  }
  o.t.assign(p + 6 * n, p + 7 * n);
  o.ms.assign(p + 7 * n, p + 7 * n + m);
}

// P2: zigzag delta along the particle order, then byte planes
static void enc2(const Node& nd, std::vector<uint8_t>& r) {
  size_t n = nd.t.size();
  r.assign(6 * n, 0);
  for (int a = 0; a < 3; ++a) {
    int32_t prev = 0;
    for (size_t k = 0; k < n; ++k) {
      int32_t v = nd.q[3 * k + a];
      uint16_t z = zz(int16_t(uint16_t(v - prev)));  // wrap mod 2^16
      prev = v;
      r[a * n + k] = uint8_t(z >> 8);
      r[(3 + a) * n + k] = uint8_t(z);
    }
  }
  r.insert(r.end(), nd.t.begin(), nd.t.end());
  r.insert(r.end(), nd.ms.begin(), nd.ms.end());
}
static void dec2(const uint8_t* p, size_t, size_t n, size_t m, Node& o) {
  o.q.resize(3 * n);
  for (int a = 0; a < 3; ++a) {
    const uint8_t* hi = p + a * n;
    const uint8_t* lo = p + (3 + a) * n;
    uint16_t* q = o.q.data() + a;
    uint16_t prev = 0;
    for (size_t k = 0; k < n; ++k) {
      prev = uint16_t(prev + unzz(uint16_t(hi[k] << 8 | lo[k])));
      q[3 * k] = prev;
    }
  }
  o.t.assign(p + 6 * n, p + 7 * n);
  o.ms.assign(p + 7 * n, p + 7 * n + m);
}

// P5: offsets from the meshlet minimum, byte planes (hi then lo), meshlet bases as planes
static void enc5(const Node& nd, std::vector<uint8_t>& r) {
  size_t n = nd.t.size(), m = nd.ms.size();
  r.assign(nd.ms.begin(), nd.ms.end());
  std::vector<uint16_t> base(3 * m);
  std::vector<uint8_t> planes(6 * n);
  size_t k0 = 0;
  for (size_t j = 0; j < m; ++j) {
    size_t c = nd.ms[j];
    for (int a = 0; a < 3; ++a) {
      uint16_t mn = 65535;
      for (size_t k = k0; k < k0 + c; ++k) mn = std::min(mn, nd.q[3 * k + a]);
      base[a * m + j] = mn;
      for (size_t k = k0; k < k0 + c; ++k) {
        uint16_t off = nd.q[3 * k + a] - mn;
        planes[a * n + k] = uint8_t(off >> 8);
        planes[(3 + a) * n + k] = uint8_t(off);
      }
    }
    k0 += c;
  }
  size_t at = r.size();
  r.resize(at + 6 * m);
  std::memcpy(r.data() + at, base.data(), 6 * m);
  r.insert(r.end(), planes.begin(), planes.end());
  r.insert(r.end(), nd.t.begin(), nd.t.end());
}
static void dec5(const uint8_t* p, size_t, size_t n, size_t m, Node& o) {
  o.ms.assign(p, p + m);
  const uint8_t* b = p + m;
  const uint8_t* pl = b + 6 * m;
  o.q.resize(3 * n);
  for (int a = 0; a < 3; ++a) {
    const uint8_t* hi = pl + a * n;
    const uint8_t* lo = pl + (3 + a) * n;
    uint16_t* q = o.q.data() + a;
    size_t k = 0;
    for (size_t j = 0; j < m; ++j) {
      uint16_t base;
      std::memcpy(&base, b + 2 * (a * m + j), 2);
      for (size_t e = k + o.ms[j]; k < e; ++k) q[3 * k] = uint16_t(base + (hi[k] << 8 | lo[k]));
    }
  }
  o.t.assign(pl + 6 * n, pl + 7 * n);
}

// P3/P4: offsets from the meshlet minimum, bit-packed per meshlet with per-axis widths.
// Layout: meshlet_size[m] | base u16[3][m] (planes) | widths u16[m] (x|y<<5|z<<10) |
//         [P4: tbase u8[m] | twidth u8[m]] [P3: types u8[n]] | bitstream (axis-major per meshlet)
template <bool kPackTypes>
static void enc_bp(const Node& nd, std::vector<uint8_t>& r) {
  size_t n = nd.t.size(), m = nd.ms.size();
  r.assign(nd.ms.begin(), nd.ms.end());
  std::vector<uint16_t> base(3 * m), widths(m);
  std::vector<uint8_t> tb(m), tw(m);
  size_t k0 = 0;
  for (size_t j = 0; j < m; ++j) {
    size_t c = nd.ms[j];
    uint16_t w = 0;
    for (int a = 0; a < 3; ++a) {
      uint16_t mn = 65535, mx = 0;
      for (size_t k = k0; k < k0 + c; ++k) mn = std::min(mn, nd.q[3 * k + a]), mx = std::max(mx, nd.q[3 * k + a]);
      base[a * m + j] = mn;
      w |= uint16_t(std::bit_width(unsigned(mx - mn))) << (5 * a);
    }
    widths[j] = w;
    uint8_t tmn = 255, tmx = 0;
    for (size_t k = k0; k < k0 + c; ++k) tmn = std::min(tmn, nd.t[k]), tmx = std::max(tmx, nd.t[k]);
    tb[j] = tmn;
    tw[j] = uint8_t(std::bit_width(unsigned(tmx - tmn)));
    k0 += c;
  }
  size_t at = r.size();
  r.resize(at + 8 * m);
  std::memcpy(r.data() + at, base.data(), 6 * m);
  std::memcpy(r.data() + at + 6 * m, widths.data(), 2 * m);
  if (kPackTypes) {
    r.insert(r.end(), tb.begin(), tb.end());
    r.insert(r.end(), tw.begin(), tw.end());
  } else {
    r.insert(r.end(), nd.t.begin(), nd.t.end());
  }
  BitWriter bw{r};
  k0 = 0;
  for (size_t j = 0; j < m; ++j) {
    size_t c = nd.ms[j];
    for (int a = 0; a < 3; ++a) {
      int w = (widths[j] >> (5 * a)) & 31;
      for (size_t k = k0; k < k0 + c; ++k) bw.put(nd.q[3 * k + a] - base[a * m + j], w);
    }
    if (kPackTypes)
      for (size_t k = k0; k < k0 + c; ++k) bw.put(nd.t[k] - tb[j], tw[j]);
    k0 += c;
  }
  bw.flush();
}
template <bool kPackTypes>
static void dec_bp(const uint8_t* p, size_t rawn, size_t n, size_t m, Node& o) {
  o.ms.assign(p, p + m);
  const uint8_t* b = p + m;
  const uint8_t* wp = b + 6 * m;
  const uint8_t* after = wp + 2 * m;
  const uint8_t* tbp = after;
  const uint8_t* twp = after + m;
  const uint8_t* bits;
  if (kPackTypes) {
    bits = after + 2 * m;
    o.t.resize(n);
  } else {
    o.t.assign(after, after + n);
    bits = after + n;
  }
  (void)rawn;  // caller guarantees 8 readable bytes past the end
  o.q.resize(3 * n);
  uint64_t pos = 0;
  size_t k = 0;
  uint16_t* q = o.q.data();
  for (size_t j = 0; j < m; ++j) {
    const size_t c = o.ms[j];
    uint16_t w16;
    std::memcpy(&w16, wp + 2 * j, 2);
    for (int a = 0; a < 3; ++a) {
      const unsigned w = (w16 >> (5 * a)) & 31;
      const uint64_t mask = (uint64_t(1) << w) - 1;
      uint16_t base;
      std::memcpy(&base, b + 2 * (a * m + j), 2);
      for (size_t e = 0; e < c; ++e) {
        uint64_t word;
        std::memcpy(&word, bits + (pos >> 3), 8);
        q[3 * (k + e) + a] = uint16_t(base + ((word >> (pos & 7)) & mask));
        pos += w;
      }
    }
    if (kPackTypes) {
      const unsigned w = twp[j];
      const uint64_t mask = (uint64_t(1) << w) - 1;
      for (size_t e = 0; e < c; ++e) {
        uint64_t word;
        std::memcpy(&word, bits + (pos >> 3), 8);
        o.t[k + e] = uint8_t(tbp[j] + ((word >> (pos & 7)) & mask));
        pos += w;
      }
    }
    k += c;
  }
}

static Layout layouts[] = {
    {"P0 interleaved (current)", enc0, dec0},
    {"P1 byte planes", enc1, dec1},
    {"P2 zigzag delta + byte planes", enc2, dec2},
    {"P5 meshlet offsets, byte planes", enc5, dec5},
    {"P3 meshlet bitpack, type plane", enc_bp<false>, dec_bp<false>},
    {"P4 meshlet bitpack, packed types", enc_bp<true>, dec_bp<true>},
};

// ---------------------------------------------------------------- voxel refs
static std::vector<uint8_t> vox_planes(const std::vector<Node>& nodes) {
  std::vector<uint32_t> d, c;
  for (const auto& nd : nodes) {
    uint32_t prev = 0;
    for (auto& v : nd.vox) d.push_back(v.voxel - prev), prev = v.voxel, c.push_back(v.count);
  }
  size_t R = d.size();
  std::vector<uint8_t> r(8 * R);
  for (size_t i = 0; i < R; ++i)
    for (int b = 0; b < 4; ++b) r[b * R + i] = uint8_t(d[i] >> (8 * b)), r[(4 + b) * R + i] = uint8_t(c[i] >> (8 * b));
  return r;
}
static std::vector<uint8_t> vox_planes_global(const std::vector<Node>& nodes) {
  std::vector<uint32_t> d, c;
  uint32_t prev = 0;
  for (const auto& nd : nodes)
    for (auto& v : nd.vox) d.push_back(v.voxel - prev), prev = v.voxel, c.push_back(v.count);
  size_t R = d.size();
  std::vector<uint8_t> r(8 * R);
  for (size_t i = 0; i < R; ++i)
    for (int b = 0; b < 4; ++b) r[b * R + i] = uint8_t(d[i] >> (8 * b)), r[(4 + b) * R + i] = uint8_t(c[i] >> (8 * b));
  return r;
}
static std::vector<uint8_t> planes32(const std::vector<uint32_t>& d) {
  size_t R = d.size();
  std::vector<uint8_t> r(4 * R);
  for (size_t i = 0; i < R; ++i)
    for (int b = 0; b < 4; ++b) r[b * R + i] = uint8_t(d[i] >> (8 * b));
  return r;
}
static std::vector<uint8_t> vox_varint(const std::vector<Node>& nodes) {
  std::vector<uint8_t> r;
  auto put = [&](uint32_t v) {
    while (v >= 128) r.push_back(uint8_t(v | 128)), v >>= 7;
    r.push_back(uint8_t(v));
  };
  for (const auto& nd : nodes) {
    uint32_t prev = 0;
    for (auto& v : nd.vox) put(v.voxel - prev), prev = v.voxel;
    for (auto& v : nd.vox) put(v.count - 1);
  }
  return r;
}

int main(int argc, char** argv) {
  int reps = 5;
  std::printf("| layout | scene | payload B/p | total B/p (other sections as stored) | LZ4 ratio | decode MB/s |\n|---|---|---|---|---|---|\n");
  for (int ai = 1; ai < argc; ++ai) {
    auto rr = StoreReader::open(argv[ai]);
    if (!rr.ok()) {
      std::fprintf(stderr, "%s\n", rr.error().message.c_str());
      return 1;
    }
    const StoreReader& rd = **rr;
    std::vector<Node> nodes(rd.nodes().size());
    NodeData d;
    std::vector<uint8_t> scratch;
    uint64_t np = 0, decoded = 0;
    for (uint32_t i = 0; i < nodes.size(); ++i) {
      if (!rd.read_node(i, d, scratch).ok()) return 2;
      nodes[i].q = d.qpos;
      nodes[i].t = d.type_index;
      nodes[i].ms = d.meshlet_size;
      auto v = rd.voxels(i);
      nodes[i].vox.assign(v.begin(), v.end());
      np += d.type_index.size();
      decoded += 7 * d.type_index.size() + d.meshlet_size.size();
    }
    const FileHeader& h = rd.header();
    const uint64_t other = rd.file_bytes() - h.payload_bytes;
    std::string scene = argv[ai];
    scene = scene.substr(scene.find_last_of('/') + 1);
    // voxel section variants
    {
      std::vector<uint8_t> raw;
      for (auto& nd : nodes)
        raw.insert(raw.end(), (const uint8_t*)nd.vox.data(), (const uint8_t*)(nd.vox.data() + nd.vox.size()));
      { auto dc = rd.density_counts(); std::vector<uint32_t> dv(dc.begin(), dc.end());
        std::vector<uint8_t> dr((const uint8_t*)dv.data(), (const uint8_t*)(dv.data()+dv.size()));
        std::fprintf(stderr, "%s density lz4 %.3f planes+lz4 %.3f; voxels global-delta planes+lz4 %.3f\n", scene.c_str(), lz4(dr).size()/double(np), lz4(planes32(dv)).size()/double(np), lz4(vox_planes_global(nodes)).size()/double(np)); }
      std::fprintf(stderr, "%s voxels: raw %.3f  lz4 %.3f  planes+lz4 %.3f  varint %.3f  varint+lz4 %.3f B/p; density %.3f\n",
                   scene.c_str(), raw.size() / double(np), lz4(raw).size() / double(np),
                   lz4(vox_planes(nodes)).size() / double(np), vox_varint(nodes).size() / double(np),
                   lz4(vox_varint(nodes)).size() / double(np), h.sections[kSectionDensity].bytes / double(np));
    }
    {  // the implemented reader: read_node (pread + XXH3 + LZ4 + decode + validation), decode_payload alone
      std::vector<std::vector<uint8_t>> comp(nodes.size());
      for (uint32_t i = 0; i < nodes.size(); ++i)
        if (!rd.read_payload(i, comp[i]).ok()) return 5;
      double best_read = 1e30, best_dec = 1e30;
      for (int rep = 0; rep < reps; ++rep) {
        auto t0 = std::chrono::steady_clock::now();
        for (uint32_t i = 0; i < nodes.size(); ++i)
          if (!rd.read_node(i, d, scratch).ok()) return 6;
        auto t1 = std::chrono::steady_clock::now();
        for (uint32_t i = 0; i < nodes.size(); ++i)
          if (!rd.decode_payload(i, comp[i], d).ok()) return 7;
        auto t2 = std::chrono::steady_clock::now();
        best_read = std::min(best_read, std::chrono::duration<double>(t1 - t0).count());
        best_dec = std::min(best_dec, std::chrono::duration<double>(t2 - t1).count());
      }
      std::printf("| StoreReader (%s): payload %.3f B/p, file %.3f B/p | read_node %.0f MB/s | decode_payload %.0f MB/s |\n",
                  scene.c_str(), h.payload_bytes / double(np), rd.file_bytes() / double(np), decoded / best_read / 1e6,
                  decoded / best_dec / 1e6);
    }
    for (const Layout& L : layouts) {
      std::vector<std::vector<uint8_t>> comp(nodes.size());
      std::vector<size_t> rawn(nodes.size());
      uint64_t cbytes = 0, rbytes = 0;
      std::vector<uint8_t> raw;
      for (size_t i = 0; i < nodes.size(); ++i) {
        L.enc(nodes[i], raw);
        rawn[i] = raw.size();
        rbytes += raw.size();
        comp[i] = lz4(raw);
        cbytes += comp[i].size();
      }
      // decode, verify once, time best of reps
      std::vector<uint8_t> buf;
      Node out;
      double best = 1e30;
      for (int rep = 0; rep < reps; ++rep) {
        auto t0 = std::chrono::steady_clock::now();
        for (size_t i = 0; i < nodes.size(); ++i) {
          buf.resize(rawn[i] + 8);
          int got = LZ4_decompress_safe((const char*)comp[i].data(), (char*)buf.data(), int(comp[i].size()), int(rawn[i]));
          if (got != int(rawn[i])) return 3;
          std::memset(buf.data() + rawn[i], 0, 8);
          L.dec(buf.data(), rawn[i], nodes[i].t.size(), nodes[i].ms.size(), out);
          if (rep == 0 && (out.q != nodes[i].q || out.t != nodes[i].t || out.ms != nodes[i].ms)) {
            std::fprintf(stderr, "%s: mismatch node %zu\n", L.name, i);
            return 4;
          }
        }
        double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        best = std::min(best, s);
      }
      std::printf("| %s | %s | %.3f | %.3f | %.3f | %.0f |\n", L.name, scene.c_str(), cbytes / double(np),
                  (cbytes + other) / double(np), rbytes / double(cbytes), decoded / best / 1e6);
    }
  }
}
