// MMPLD reader (format described in mmpld_reader.h; reference: MegaMol
// plugins/datatools/src/io/MMPLDDataSource.cpp and the VISUS mmpld library).
#include "readers/mmpld_reader.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "readers/reader_factories.h"

namespace mds {

static_assert(std::endian::native == std::endian::little, "MMPLD reader assumes a little-endian host");

namespace {

constexpr uint64_t kHeaderSize = 6 + 2 + 4 + 24 + 24;  // magic, version, frames, bbox, clipbox
constexpr uint64_t kChunkBytes = uint64_t{16} << 20;    // bounded read buffer

// Per-particle vertex bytes by vertex type (MegaMol MMPLDDataSource); -1 = unknown type.
int vertex_size(uint8_t t) {
  switch (t) {
    case 0: return 0;    // NONE
    case 1: return 12;   // FLOAT_XYZ
    case 2: return 16;   // FLOAT_XYZR
    case 3: return 6;    // SHORT_XYZ (3 x int16)
    case 4: return 24;   // DOUBLE_XYZ
    default: return -1;
  }
}

int colour_size(uint8_t t) {
  switch (t) {
    case 0: return 0;    // NONE (global colour in the list header)
    case 1: return 3;    // UINT8_RGB
    case 2: return 4;    // UINT8_RGBA
    case 3: return 4;    // FLOAT_I
    case 4: return 12;   // FLOAT_RGB
    case 5: return 16;   // FLOAT_RGBA
    case 6: return 8;    // USHORT_RGBA
    case 7: return 8;    // DOUBLE_I
    default: return -1;
  }
}

const char* vertex_name(uint8_t t) {
  static const char* names[] = {"NONE", "FLOAT_XYZ", "FLOAT_XYZR", "SHORT_XYZ", "DOUBLE_XYZ"};
  return t < 5 ? names[t] : "unknown";
}

// Cursor inside one frame: every read is checked against the frame end (and, through
// BinaryFile, against the file size).
struct FrameCursor {
  const BinaryFile& file;
  uint64_t pos;
  uint64_t end;
  uint64_t frame;

  template <class T>
  Result<T> take(const char* what) {
    if (pos > end || sizeof(T) > end - pos) {
      return make_error(Errc::format, "{}: byte offset {}: frame {}: {} runs past the frame end at byte {}",
                        file.name(), pos, frame, what, end);
    }
    MDS_ASSIGN_OR_RETURN(T v, file.read_pod<T>(pos, what));
    pos += sizeof(T);
    return v;
  }
  Status skip(uint64_t n, const char* what) {
    if (pos > end || n > end - pos) {
      return make_error(Errc::format, "{}: byte offset {}: frame {}: {} ({} bytes) runs past the frame end at byte {}",
                        file.name(), pos, frame, what, n, end);
    }
    pos += n;
    return Status::success();
  }
};

struct Box6 {
  float v[6];
};

}  // namespace

Status MmpldReader::parse_frame(uint64_t begin, uint64_t end, bool with_timestamp) {
  // Parses the frame assuming the version's layout; on success lists_ is filled and the
  // lists end exactly at `end`.
  lists_.clear();
  const uint64_t frame = info_.timestep < 0 ? 0 : static_cast<uint64_t>(info_.timestep);
  FrameCursor c{file_, begin, end, frame};
  if (with_timestamp) {
    MDS_ASSIGN_OR_RETURN(float timestamp, c.take<float>("frame timestamp"));
    (void)timestamp;
  }
  const uint64_t list_count_at = c.pos;
  MDS_ASSIGN_OR_RETURN(uint32_t list_count, c.take<uint32_t>("list count"));
  // The smallest list header is 10 bytes (types + particle count).
  if (list_count > (c.end - c.pos) / 10 || list_count >= static_cast<uint32_t>(std::numeric_limits<int32_t>::max())) {
    return make_error(Errc::range, "{}: byte offset {}: frame {}: list count {} cannot fit in the frame's {} bytes",
                      file_.name(), list_count_at, frame, list_count, end - begin);
  }
  for (uint32_t li = 0; li < list_count; ++li) {
    MmpldList l;
    const uint64_t list_at = c.pos;
    MDS_ASSIGN_OR_RETURN(l.vertex_type, c.take<uint8_t>("vertex type"));
    MDS_ASSIGN_OR_RETURN(l.colour_type, c.take<uint8_t>("colour type"));
    const int vs = vertex_size(l.vertex_type);
    const int cs = colour_size(l.colour_type);
    if (vs < 0) {
      return make_error(Errc::unsupported, "{}: byte offset {}: frame {} list {}: unknown vertex type {}",
                        file_.name(), list_at, frame, li, l.vertex_type);
    }
    if (cs < 0) {
      return make_error(Errc::unsupported, "{}: byte offset {}: frame {} list {}: unknown colour type {}",
                        file_.name(), list_at + 1, frame, li, l.colour_type);
    }
    l.vertex_size = static_cast<uint32_t>(vs);
    // MegaMol: a list without positions has no per-particle data at all.
    l.stride = l.vertex_type == 0 ? 0u : static_cast<uint32_t>(vs + cs);
    if (l.vertex_type == 1 || l.vertex_type == 3 || l.vertex_type == 4) {
      const uint64_t at = c.pos;
      MDS_ASSIGN_OR_RETURN(l.global_radius, c.take<float>("global radius"));
      if (!std::isfinite(l.global_radius) || l.global_radius < 0) {
        return make_error(Errc::range, "{}: byte offset {}: frame {} list {}: invalid global radius {}", file_.name(),
                          at, frame, li, l.global_radius);
      }
      l.has_global_radius = true;
    }
    if (l.colour_type == 0) {
      MDS_ASSIGN_OR_RETURN(const uint32_t rgba, c.take<uint32_t>("global colour"));  // bytes R, G, B, A
      l.global_colour = rgba;
    } else if (l.colour_type == 3 || l.colour_type == 7) {
      // Two floats also for DOUBLE_I (MMPLD 1.3 quirk); kept as written (not validated: unused).
      MDS_ASSIGN_OR_RETURN(l.intensity_range[0], c.take<float>("intensity range"));
      MDS_ASSIGN_OR_RETURN(l.intensity_range[1], c.take<float>("intensity range"));
    }
    const uint64_t count_at = c.pos;
    MDS_ASSIGN_OR_RETURN(l.count, c.take<uint64_t>("particle count"));
    if (version_ == 103) MDS_TRY(c.skip(24, "list bounding box"));
    l.data_offset = c.pos;
    if (l.stride > 0 && l.count > (c.end - c.pos) / l.stride) {
      return make_error(Errc::range,
                        "{}: byte offset {}: frame {} list {}: particle count {} x {} bytes exceeds the {} bytes left "
                        "in the frame",
                        file_.name(), count_at, frame, li, l.count, l.stride, c.end - c.pos);
    }
    MDS_TRY(c.skip(l.count * l.stride, "particle data"));
    if (version_ == 101) {
      MDS_ASSIGN_OR_RETURN(uint32_t clusters, c.take<uint32_t>("cluster count"));
      (void)clusters;
      MDS_ASSIGN_OR_RETURN(uint64_t cluster_bytes, c.take<uint64_t>("cluster data size"));
      MDS_TRY(c.skip(cluster_bytes, "cluster data"));
    }
    lists_.push_back(l);
  }
  if (c.pos != end) {
    return make_error(Errc::format, "{}: byte offset {}: frame {}: {} trailing bytes after the last list (frame ends at {})",
                      file_.name(), c.pos, frame, end - c.pos, end);
  }
  return Status::success();
}

Result<std::unique_ptr<ParticleReader>> MmpldReader::open(const std::filesystem::path& path,
                                                          const ReaderOptions& options) {
  MDS_ASSIGN_OR_RETURN(BinaryFile file, BinaryFile::open(path));
  std::unique_ptr<MmpldReader> r(new MmpldReader(std::move(file)));
  const BinaryFile& f = r->file_;
  char magic[6];
  MDS_TRY(f.read_at(0, magic, 6, "MMPLD magic"));
  if (std::memcmp(magic, "MMPLD\0", 6) != 0) {
    return make_error(Errc::format, "{}: byte offset 0: not an MMPLD file (magic \"MMPLD\\0\" missing)", f.name());
  }
  MDS_ASSIGN_OR_RETURN(r->version_, f.read_pod<uint16_t>(6, "version"));
  if (r->version_ < 100 || r->version_ > 103) {
    return make_error(Errc::unsupported, "{}: byte offset 6: MMPLD version {} not supported (100-103)", f.name(),
                      r->version_);
  }
  MDS_ASSIGN_OR_RETURN(r->frame_count_, f.read_pod<uint32_t>(8, "frame count"));
  if (r->frame_count_ == 0) return make_error(Errc::format, "{}: byte offset 8: MMPLD file has no frames", f.name());
  const uint64_t table_bytes = (uint64_t{r->frame_count_} + 1) * 8;
  if (table_bytes > f.size() - std::min(f.size(), kHeaderSize)) {
    return make_error(Errc::range, "{}: byte offset 8: frame count {} needs a {}-byte frame table; file has {} bytes",
                      f.name(), r->frame_count_, table_bytes, f.size());
  }
  MDS_ASSIGN_OR_RETURN(Box6 bbox, f.read_pod<Box6>(12, "bounding box"));
  if (std::all_of(bbox.v, bbox.v + 6, [](float v) { return std::isfinite(v); }) && bbox.v[0] <= bbox.v[3] &&
      bbox.v[1] <= bbox.v[4] && bbox.v[2] <= bbox.v[5]) {
    r->info_.has_box = true;
    for (int k = 0; k < 3; ++k) {
      r->info_.box_lo[k] = bbox.v[k];
      r->info_.box_hi[k] = bbox.v[k + 3];
    }
    // MegaMol draws the data set's bounding box as the box around the data: the cell (not periodic).
    r->info_.cell = SimulationCell::box(r->info_.box_lo, r->info_.box_hi);
  }

  int64_t frame = options.frame;
  if (frame == -1) frame = int64_t{r->frame_count_} - 1;
  if (frame < 0 || frame >= int64_t{r->frame_count_}) {
    return make_error(Errc::invalid_argument, "{}: frame {} requested but the file has {} frames", f.name(),
                      options.frame, r->frame_count_);
  }
  const uint64_t entry = kHeaderSize + static_cast<uint64_t>(frame) * 8;
  MDS_ASSIGN_OR_RETURN(uint64_t begin, f.read_pod<uint64_t>(entry, "frame table entry"));
  MDS_ASSIGN_OR_RETURN(uint64_t end, f.read_pod<uint64_t>(entry + 8, "frame table entry"));
  const uint64_t data_start = kHeaderSize + table_bytes;
  if (begin < data_start || end < begin || end > f.size()) {
    return make_error(Errc::range,
                      "{}: byte offset {}: frame {} spans bytes [{}, {}), outside the frame data [{}, {}) of the file",
                      f.name(), entry, frame, begin, end, data_start, f.size());
  }
  r->info_.timestep = frame;  // MMPLD has no simulation step; the frame index stands in
  r->info_.frame_count = r->frame_count_;
  Status st = r->parse_frame(begin, end, r->version_ >= 102);
  if (!st.ok() && r->version_ == 103) {
    // MegaMol before commit fc4e784 wrote version-103 files without the frame timestamp;
    // accept such a frame only when it parses exactly (to the frame end) without it.
    if (r->parse_frame(begin, end, false).ok()) st = Status::success();
  }
  if (!st.ok()) return st.error();

  for (size_t i = 0; i < r->lists_.size(); ++i) {
    const MmpldList& l = r->lists_[i];
    const auto type = static_cast<int32_t>(i + 1);
    if (l.vertex_type == 0) continue;
    r->info_.particle_count += l.count;
    if (l.vertex_type == 2) r->info_.has_radius = true;
    if (l.has_global_radius) r->info_.type_radius[type] = l.global_radius;
  }
  if (!options.property.empty()) {
    // MMPLD's one per-particle scalar is the intensity of the FLOAT_I / DOUBLE_I colour types.
    if (options.property != "intensity")
      return make_error(Errc::format,
                        "{}: MMPLD particles have no property '{}' (--property): the one per-particle scalar MMPLD "
                        "stores is 'intensity' (colour types FLOAT_I, DOUBLE_I)",
                        f.name(), options.property);
    for (size_t i = 0; i < r->lists_.size(); ++i) {
      const MmpldList& l = r->lists_[i];
      if (l.vertex_type != 0 && l.colour_type != 3 && l.colour_type != 7)
        return make_error(Errc::format,
                          "{}: byte offset {}: frame {} list {}: colour type {} carries no intensity (--property "
                          "intensity needs FLOAT_I or DOUBLE_I in every list)",
                          f.name(), l.data_offset, frame, i, l.colour_type);
    }
    r->intensity_ = true;
    r->info_.has_property = true;
  }
  if (options.color) {
    for (size_t i = 0; i < r->lists_.size(); ++i) {
      const MmpldList& l = r->lists_[i];
      if (l.vertex_type != 0 && (l.colour_type == 3 || l.colour_type == 7))
        return make_error(Errc::format,
                          "{}: byte offset {}: frame {} list {}: colour type {} is an intensity, not a colour (--color "
                          "needs NONE, UINT8_RGB(A), FLOAT_RGB(A) or USHORT_RGBA; keep it with --property intensity)",
                          f.name(), l.data_offset, frame, i, l.colour_type == 3 ? "FLOAT_I" : "DOUBLE_I");
    }
    r->colour_ = true;
    r->info_.has_color = true;
  }
  return std::unique_ptr<ParticleReader>(std::move(r));
}

Result<uint32_t> MmpldReader::colour(const MmpldList& l, const unsigned char* p, uint64_t at, uint64_t index) const {
  switch (l.colour_type) {
    case 0: return l.global_colour;
    case 1: return pack_rgba8(p[0], p[1], p[2]);
    case 2: return pack_rgba8(p[0], p[1], p[2], p[3]);
    case 6: {
      uint16_t v[4];
      std::memcpy(v, p, 8);
      return pack_rgba8((v[0] * 255u + 32767u) / 65535u, (v[1] * 255u + 32767u) / 65535u,
                        (v[2] * 255u + 32767u) / 65535u, (v[3] * 255u + 32767u) / 65535u);
    }
    default: {  // 4 FLOAT_RGB, 5 FLOAT_RGBA
      float v[4] = {0, 0, 0, 1};
      std::memcpy(v, p, l.colour_type == 4 ? 12 : 16);
      for (int k = 0; k < 4; ++k)
        if (!std::isfinite(v[k]))
          return make_error(Errc::range, "{}: byte offset {}: list {} particle {}: non-finite colour channel {}",
                            file_.name(), at + 4 * k, cur_list_, index, v[k]);
      return pack_rgba8(unit_to_u8(v[0]), unit_to_u8(v[1]), unit_to_u8(v[2]), unit_to_u8(v[3]));
    }
  }
}

Result<size_t> MmpldReader::read(ParticleBatch& out, size_t max_particles) {
  out.clear();
  size_t appended = 0;
  while (appended < max_particles && cur_list_ < lists_.size()) {
    const MmpldList& l = lists_[cur_list_];
    if (l.vertex_type == 0 || cur_index_ >= l.count) {
      ++cur_list_;
      cur_index_ = 0;
      continue;
    }
    const uint64_t n = std::min<uint64_t>({l.count - cur_index_, max_particles - appended,
                                           std::max<uint64_t>(1, kChunkBytes / l.stride)});
    const uint64_t at = l.data_offset + cur_index_ * l.stride;
    buffer_.resize(static_cast<size_t>(n * l.stride));
    MDS_TRY(file_.read_at(at, buffer_.data(), buffer_.size(), "particle data"));
    const auto type = static_cast<int32_t>(cur_list_ + 1);
    for (uint64_t i = 0; i < n; ++i) {
      const unsigned char* p = buffer_.data() + i * l.stride;
      double xyz[3];
      float radius = l.global_radius;
      switch (l.vertex_type) {
        case 1:
        case 2: {
          float v[4];
          std::memcpy(v, p, l.vertex_size);
          xyz[0] = v[0], xyz[1] = v[1], xyz[2] = v[2];
          if (l.vertex_type == 2) radius = v[3];
          break;
        }
        case 3: {
          int16_t v[3];
          std::memcpy(v, p, 6);
          xyz[0] = v[0], xyz[1] = v[1], xyz[2] = v[2];
          break;
        }
        default: {
          std::memcpy(xyz, p, 24);
          break;
        }
      }
      if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2])) {
        return make_error(Errc::range, "{}: byte offset {}: list {} ({}) particle {}: non-finite coordinate",
                          file_.name(), at + i * l.stride, cur_list_, vertex_name(l.vertex_type), cur_index_ + i);
      }
      if (!std::isfinite(radius) || radius < 0) {
        return make_error(Errc::range, "{}: byte offset {}: list {} particle {}: invalid radius {}", file_.name(),
                          at + i * l.stride + 12, cur_list_, cur_index_ + i, radius);
      }
      out.x.push_back(xyz[0]);
      out.y.push_back(xyz[1]);
      out.z.push_back(xyz[2]);
      out.type.push_back(type);
      if (info_.has_radius) out.radius.push_back(radius);
      if (intensity_) {
        double v;
        if (l.colour_type == 3) {
          float f;
          std::memcpy(&f, p + l.vertex_size, 4);
          v = f;
        } else {
          std::memcpy(&v, p + l.vertex_size, 8);
        }
        if (!std::isfinite(v) || !std::isfinite(static_cast<float>(v)))
          return make_error(Errc::range, "{}: byte offset {}: list {} particle {}: non-finite intensity {}", file_.name(),
                            at + i * l.stride + l.vertex_size, cur_list_, cur_index_ + i, v);
        out.property.push_back(static_cast<float>(v));
      }
      if (colour_) {
        MDS_ASSIGN_OR_RETURN(const uint32_t rgba, colour(l, p + l.vertex_size, at + i * l.stride + l.vertex_size,
                                                           cur_index_ + i));
        out.color.push_back(rgba);
      }
    }
    appended += n;
    cur_index_ += n;
  }
  return appended;
}

Result<std::unique_ptr<ParticleReader>> open_mmpld_reader(const std::filesystem::path& path,
                                                          const ReaderOptions& options) {
  return MmpldReader::open(path, options);
}

}  // namespace mds
