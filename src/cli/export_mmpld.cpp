// `mdstream export STORE -o OUT.mmpld`: the store as MMPLD 1.0 for MegaMol; see export_nodes.h.
// Layout (readers/mmpld_reader.h, MegaMol's MMPLDDataSource):
//   header  "MMPLD\0", uint16 version 100, uint32 frames 1, float bbox[6], float clipbox[6],
//           uint64 frame offsets[2]                                        60 + 16 bytes
//   frame   uint32 list count, then per type: uint8 vertex type, uint8 colour type,
//           (float global radius: FLOAT_XYZ), (uint8 colour[4]: NONE), (float range[2]: FLOAT_I),
//           uint64 count, count x (vertex + colour) bytes
// The lists' sizes are known before any particle is written (the types' counts), so each list
// gets its byte range up front and its particles go there through their own buffer (pwrite):
// one pass over the nodes, however the types are spread over them.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "cli/export_nodes.h"
#include "store/file_io.h"
#include "store/type_style.h"

namespace mds::cli {
namespace {

constexpr uint64_t kHeaderBytes = 6 + 2 + 4 + 24 + 24 + 16;  // magic, version, frames, bbox, clipbox, offsets[2]
constexpr size_t kListBufferBytes = 64 << 10;  // per type: at most 256 x (64 KiB + a particle) = 16 MiB

enum : uint8_t { kFloatXyz = 1, kFloatXyzr = 2 };
enum : uint8_t { kColourNone = 0, kUint8Rgba = 2, kFloatI = 3 };

template <class T>
void put(std::vector<uint8_t>& b, T v) {
  const size_t at = b.size();
  b.resize(at + sizeof(T));
  std::memcpy(b.data() + at, &v, sizeof(T));
}

// One type's list: where its particles go, and their pending bytes.
struct ListOut {
  uint64_t next = 0;  // file offset of the next particle
  std::vector<uint8_t> pending;
};

}  // namespace

Status export_mmpld(const store::StoreReader& reader, const ExportFilter& filter, const std::filesystem::path& output) {
  const store::FileHeader& h = reader.header();
  const auto types = reader.types();
  const auto nodes = reader.nodes();
  const bool radius = (h.flags & store::kFlagPerParticleRadius) != 0;
  const bool color = (h.flags & store::kFlagColor) != 0;
  const bool property = !color && (h.flags & store::kFlagProperty) != 0;
  const uint8_t vertex = radius ? kFloatXyzr : kFloatXyz;
  const uint8_t colour = color ? kUint8Rgba : property ? kFloatI : kColourNone;
  const uint64_t stride = (radius ? 16 : 12) + (color || property ? 4 : 0);

  // Particles per type: the directory's counts, or with a filter the kept ones (a first pass
  // decodes every node it may keep any of: the directory has no per-type counts per node).
  std::vector<uint64_t> counts(types.size(), 0);
  store::NodeData node;
  std::vector<uint8_t> scratch;
  if (!filter.any()) {
    for (size_t t = 0; t < types.size(); ++t) counts[t] = types[t].particle_count;
  } else {
    for (uint32_t i = 0; i < nodes.size(); ++i) {
      const store::SliceCover cover = filter.cover(i, nodes[i]);
      if (cover == store::SliceCover::none) continue;
      MDS_TRY(reader.read_node(i, node, scratch));
      for (size_t k = 0; k < node.particle_count(); ++k)
        if (filter.keeps(cover, centre(nodes[i], node, k), node, k)) ++counts[node.type_index[k]];
    }
    uint64_t total = 0;
    for (const uint64_t c : counts) total += c;
    if (total == 0) return filter.nothing_kept(reader);
  }

  // Header, frame table and list headers; each list's particle bytes follow its header.
  std::vector<uint8_t> head;
  head.insert(head.end(), {'M', 'M', 'P', 'L', 'D', '\0'});
  put<uint16_t>(head, 100);
  put<uint32_t>(head, 1);
  // The bounding box: the simulation cell's where the store has one (MegaMol draws it as the data
  // set's box; the MMPLD reader takes it back as a cell that is not periodic), else the spheres'.
  // The clip box holds both.
  const double pad = h.radius_max;  // the spheres, not only their centres
  double clip_lo[3], clip_hi[3], box_lo[3], box_hi[3];
  for (int a = 0; a < 3; ++a) {
    box_lo[a] = clip_lo[a] = h.bounds_min[a] - pad;
    box_hi[a] = clip_hi[a] = h.bounds_max[a] + pad;
  }
  if (const auto& cell = reader.cell()) {
    cell->bounds(box_lo, box_hi);
    for (int a = 0; a < 3; ++a) {
      clip_lo[a] = std::min(clip_lo[a], box_lo[a]);
      clip_hi[a] = std::max(clip_hi[a], box_hi[a]);
    }
  }
  for (int a = 0; a < 3; ++a) put<float>(head, float(box_lo[a]));
  for (int a = 0; a < 3; ++a) put<float>(head, float(box_hi[a]));
  for (int a = 0; a < 3; ++a) put<float>(head, float(clip_lo[a]));
  for (int a = 0; a < 3; ++a) put<float>(head, float(clip_hi[a]));
  const size_t offsets_at = head.size();
  put<uint64_t>(head, kHeaderBytes);
  put<uint64_t>(head, 0);  // the end, below
  put<uint32_t>(head, uint32_t(types.size()));  // the frame's list count
  // Each list: its header, then its particles, after the lists before it.
  std::vector<std::vector<uint8_t>> headers(types.size());
  std::vector<ListOut> lists(types.size());
  uint64_t end = head.size();
  for (size_t t = 0; t < types.size(); ++t) {
    lists[t].pending.reserve(kListBufferBytes + stride);  // flushed when full: never grows beyond
    std::vector<uint8_t>& lh = headers[t];
    put<uint8_t>(lh, vertex);
    put<uint8_t>(lh, colour);
    if (vertex == kFloatXyz) put<float>(lh, types[t].radius);
    if (colour == kColourNone) {
      const store::Srgb c = store::default_type_color(uint32_t(t));
      for (const float v : {c.r, c.g, c.b}) put<uint8_t>(lh, uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)));
      put<uint8_t>(lh, 255);
    }
    if (colour == kFloatI) {
      put<float>(lh, h.property_min);
      put<float>(lh, h.property_max);
    }
    put<uint64_t>(lh, counts[t]);
    lists[t].next = end + lh.size();
    end = lists[t].next + counts[t] * stride;
  }
  std::memcpy(head.data() + offsets_at + 8, &end, 8);

  MDS_ASSIGN_OR_RETURN(auto out, store::AtomicOutput::create(output));
  MDS_TRY(out.file().pwrite_all(head.data(), head.size(), 0));
  for (size_t t = 0; t < types.size(); ++t)
    MDS_TRY(out.file().pwrite_all(headers[t].data(), headers[t].size(), lists[t].next - headers[t].size()));
  auto flush = [&](ListOut& l) -> Status {
    if (l.pending.empty()) return {};
    MDS_TRY(out.file().pwrite_all(l.pending.data(), l.pending.size(), l.next));
    l.next += l.pending.size();
    l.pending.clear();
    return {};
  };

  const double rstep = (double(h.radius_max) - double(h.radius_min)) / double(store::kQuantMax);
  std::vector<uint64_t> written(types.size(), 0);
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    const store::NodeEntry& e = nodes[i];
    const store::SliceCover cover = filter.cover(i, e);
    if (cover == store::SliceCover::none) continue;
    MDS_TRY(reader.read_node(i, node, scratch));
    for (size_t k = 0; k < node.particle_count(); ++k) {
      const std::array<double, 3> x = centre(e, node, k);
      if (!filter.keeps(cover, x, node, k)) continue;
      const uint8_t t = node.type_index[k];
      ListOut& l = lists[t];
      for (int a = 0; a < 3; ++a) put<float>(l.pending, float(x[size_t(a)]));
      if (radius) put<float>(l.pending, float(double(h.radius_min) + double(node.radius_q[k]) * rstep));
      if (color) put<uint32_t>(l.pending, node.color[k]);  // bytes R, G, B, A
      if (property) put<float>(l.pending, float(store::property_value(h.property_min, h.property_max, node.property_q[k])));
      ++written[t];
      if (l.pending.size() >= kListBufferBytes) MDS_TRY(flush(l));
    }
  }
  for (size_t t = 0; t < types.size(); ++t) {
    MDS_TRY(flush(lists[t]));
    if (written[t] != counts[t])
      return make_error(Errc::internal, "{}: type {} has {} particles, the count said {}", reader.path().string(), t,
                        written[t], counts[t]);
  }
  return out.commit();
}

}  // namespace mds::cli
