// Store reader for hostile input (docs/store-format.md, "What a reader must validate").
// open() checks the header (magic, version, size, hash, field ranges), the section layout
// (contiguous after the payloads, ending at end of file), every section hash, the type
// table, the node directory (counts, prefix sums, contiguous payload ranges, sizes), the
// voxel lists and the density volume (which must equal the sum of all voxel lists) before
// anything is handed out. Nothing is allocated from a count that was not first bounded by
// the file size. Payload reads use pread and are thread-safe.
#include "store/store_reader.h"

#include <lz4.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "culling/node_occupancy.h"
#include "store/file_io.h"
#include "store/hash.h"
#include "store/payload_codec.h"
#include "store/property_histogram.h"
#include "store/series.h"
#include "store/section_codec.h"

static_assert(std::endian::native == std::endian::little, "the store format is little-endian; port the I/O first");

namespace mds::store {

namespace {

constexpr uint64_t kMaxDensityVoxels = uint64_t(1) << 28;
constexpr const char* kSectionNames[kSectionCount] = {"type table", "node directory", "voxel lists", "density volume",
                                                      "occupancy"};

bool finite3(const double v[3]) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// Largest decoded size an LZ4 block of `bytes` stored bytes can produce (ratio < 255:1).
uint64_t lz4_max_decoded(uint64_t bytes) { return bytes * 255 + 16; }

uint64_t section_field_offset(int id, size_t field_offset) {
  return offsetof(FileHeader, sections) + uint64_t(id) * sizeof(Section) + field_offset;
}

}  // namespace

struct StoreReader::Impl {
  std::filesystem::path path;
  std::string name;
  File file;
  FileHeader header{};
  uint64_t file_bytes = 0;
  std::vector<TypeEntry> types;
  std::vector<NodeEntry> nodes;
  std::vector<VoxelRef> voxels;
  std::vector<uint32_t> density;
  std::vector<uint8_t> occupancy;  // kOccupancyBytes per node
  std::optional<SimulationCell> cell;  // with kFlagCell
  std::vector<PropertyHistogram> histograms;  // with kFlagPropertyHistogram: one per node

  Status check_header();
  Status check_sections();
  Status read_section(int id, void* dst);
  Status check_types();
  Status check_directory();
  Status check_voxels_and_density(std::span<const uint8_t> density_block);
};

#define HFIELD(f) offsetof(FileHeader, f)

Status StoreReader::Impl::check_header() {
  const FileHeader& h = header;
  if (std::memcmp(h.magic, kMagic, sizeof(kMagic)) != 0)
    return make_error(Errc::format, "{}: field magic at byte 0: not an mdstream store (bad magic)", name);
  if (h.version != kFormatVersion)
    return make_error(Errc::unsupported,
                      "{}: field version at byte {}: format version {} is not supported (this build reads {}; convert the "
                      "input again)",
                      name, HFIELD(version), h.version, kFormatVersion);
  if (h.header_bytes != kHeaderBytes)
    return make_error(Errc::format, "{}: field header_bytes at byte {}: {} (expected {})", name, HFIELD(header_bytes),
                      h.header_bytes, kHeaderBytes);
  FileHeader copy = h;
  copy.header_hash = 0;
  if (hash_bytes({reinterpret_cast<const uint8_t*>(&copy), sizeof(copy)}) != h.header_hash)
    return make_error(Errc::checksum, "{}: field header_hash at byte {}: header checksum mismatch", name, HFIELD(header_hash));
  if (h.flags & ~kKnownFlags)
    return make_error(Errc::unsupported, "{}: field flags at byte {}: unknown flag bits {:#x}", name, HFIELD(flags), h.flags);
  if (h.flags & kFlagProperty) {
    const size_t len = strnlen(h.property_name, kPropertyNameBytes);
    if (len == 0 || len == kPropertyNameBytes)
      return make_error(Errc::format, "{}: field property_name at byte {}: {} (expected 1..{} bytes and a NUL)", name,
                        HFIELD(property_name), len == 0 ? "empty" : "not NUL-terminated", kPropertyNameBytes - 1);
    for (size_t i = len; i < kPropertyNameBytes; ++i)
      if (h.property_name[i] != 0)
        return make_error(Errc::format, "{}: field property_name at byte {}: not zero after the name's NUL", name,
                          HFIELD(property_name) + i);
    if (!std::isfinite(h.property_min) || !std::isfinite(h.property_max) || h.property_min > h.property_max)
      return make_error(Errc::range, "{}: field property_min/property_max at byte {}: [{}, {}] is not a valid range", name,
                        HFIELD(property_min), h.property_min, h.property_max);
  } else {
    const auto* p = reinterpret_cast<const uint8_t*>(h.property_name);
    for (size_t i = 0; i < offsetof(FileHeader, cell) - offsetof(FileHeader, property_name); ++i)
      if (p[i] != 0) {
        const size_t at = HFIELD(property_name) + i;
        const char* field = at < HFIELD(property_min)   ? "property_name"
                            : at < HFIELD(property_max) ? "property_min"
                                                        : "property_max";
        return make_error(Errc::format, "{}: field {} at byte {}: not zero without the property flag", name, field, at);
      }
  }
  if ((h.flags & kFlagPropertyHistogram) && !(h.flags & kFlagProperty))
    return make_error(Errc::format, "{}: field flags at byte {}: property histograms without the property flag", name,
                      HFIELD(flags));
  if (!(h.flags & kFlagPropertyHistogram)) {
    const auto* p = reinterpret_cast<const uint8_t*>(&h.property_histograms);
    for (size_t i = 0; i < sizeof(h.property_histograms); ++i)
      if (p[i] != 0)
        return make_error(Errc::format, "{}: field property_histograms at byte {}: not zero without the property "
                          "histogram flag", name, HFIELD(property_histograms) + i);
  }
  if (!(h.flags & kFlagCell)) {
    const auto* p = reinterpret_cast<const uint8_t*>(&h.cell);
    for (size_t i = 0; i < sizeof(h.cell); ++i)
      if (p[i] != 0)
        return make_error(Errc::format, "{}: field cell at byte {}: not zero without the cell flag", name, HFIELD(cell) + i);
  }
  for (size_t i = 0; i < sizeof(h.reserved); ++i)
    if (h.reserved[i] != 0)
      return make_error(Errc::format, "{}: field reserved at byte {}: not zero", name, HFIELD(reserved) + i);
  if (h.node_size_max < 1 || h.node_size_max > kMaxNodeParticles)
    return make_error(Errc::range, "{}: field node_size_max at byte {}: {} outside [1, {}]", name, HFIELD(node_size_max),
                      h.node_size_max, kMaxNodeParticles);
  if (h.meshlet_size_max < 1 || h.meshlet_size_max > kMaxMeshletParticles)
    return make_error(Errc::range, "{}: field meshlet_size_max at byte {}: {} outside [1, {}]", name,
                      HFIELD(meshlet_size_max), h.meshlet_size_max, kMaxMeshletParticles);
  if (h.type_count > kMaxTypes)
    return make_error(Errc::range, "{}: field type_count at byte {}: {} exceeds {}", name, HFIELD(type_count), h.type_count,
                      kMaxTypes);
  if (h.node_count > 0 && h.type_count == 0)
    return make_error(Errc::range, "{}: field type_count at byte {}: 0 types but {} nodes", name, HFIELD(type_count),
                      h.node_count);
  if (h.particle_count < h.node_count || h.particle_count > uint64_t(h.node_count) * h.node_size_max)
    return make_error(Errc::range, "{}: field particle_count at byte {}: {} impossible for {} nodes of at most {}", name,
                      HFIELD(particle_count), h.particle_count, h.node_count, h.node_size_max);
  if (h.meshlet_count < h.node_count || h.meshlet_count > h.particle_count)
    return make_error(Errc::range, "{}: field meshlet_count at byte {}: {} outside [{}, {}]", name, HFIELD(meshlet_count),
                      h.meshlet_count, h.node_count, h.particle_count);
  const bool no_grid = h.density_dims[0] == 0 && h.density_dims[1] == 0 && h.density_dims[2] == 0;
  const uint64_t product = uint64_t(h.density_dims[0]) * h.density_dims[1] * h.density_dims[2];
  if ((!no_grid && product == 0) || product > kMaxDensityVoxels)
    return make_error(Errc::range, "{}: field density_dims at byte {}: {}x{}x{} (must be all zero or have 1..2^28 voxels)",
                      name, HFIELD(density_dims), h.density_dims[0], h.density_dims[1], h.density_dims[2]);
  if (!finite3(h.bounds_min) || !finite3(h.bounds_max))
    return make_error(Errc::range, "{}: field bounds_min/bounds_max at byte {}: not finite", name, HFIELD(bounds_min));
  if (!finite3(h.density_min) || !finite3(h.density_max))
    return make_error(Errc::range, "{}: field density_min/density_max at byte {}: not finite", name, HFIELD(density_min));
  for (int a = 0; a < 3; ++a) {
    if (h.bounds_min[a] > h.bounds_max[a])
      return make_error(Errc::range, "{}: field bounds_min at byte {}: min > max on axis {}", name,
                        HFIELD(bounds_min) + 8 * a, a);
    if (h.density_min[a] > h.density_max[a])
      return make_error(Errc::range, "{}: field density_min at byte {}: min > max on axis {}", name,
                        HFIELD(density_min) + 8 * a, a);
  }
  if (!std::isfinite(h.radius_min) || !std::isfinite(h.radius_max) || h.radius_min < 0 || h.radius_min > h.radius_max)
    return make_error(Errc::range, "{}: field radius_min/radius_max at byte {}: [{}, {}] is not a valid range", name,
                      HFIELD(radius_min), h.radius_min, h.radius_max);
  if (!std::isfinite(h.max_quantization_error) || h.max_quantization_error < 0)
    return make_error(Errc::range, "{}: field max_quantization_error at byte {}: {}", name, HFIELD(max_quantization_error),
                      h.max_quantization_error);
  if (!std::isfinite(h.max_error_over_half_step) || h.max_error_over_half_step < 0)
    return make_error(Errc::range, "{}: field max_error_over_half_step at byte {}: {}", name,
                      HFIELD(max_error_over_half_step), h.max_error_over_half_step);
  if (h.payload_bytes > file_bytes - kHeaderBytes)
    return make_error(Errc::range, "{}: field payload_bytes at byte {}: {} bytes of payloads do not fit in a {}-byte file",
                      name, HFIELD(payload_bytes), h.payload_bytes, file_bytes);
  if (h.node_count > 0 && h.payload_bytes < h.node_count)
    return make_error(Errc::range, "{}: field payload_bytes at byte {}: {} for {} nodes", name, HFIELD(payload_bytes),
                      h.payload_bytes, h.node_count);
  if (h.payload_raw_bytes != 0 && h.payload_raw_bytes > lz4_max_decoded(h.payload_bytes))
    return make_error(Errc::range, "{}: field payload_raw_bytes at byte {}: {} cannot come from {} compressed bytes", name,
                      HFIELD(payload_raw_bytes), h.payload_raw_bytes, h.payload_bytes);
  return {};
}

Status StoreReader::Impl::check_sections() {
  const FileHeader& h = header;
  const uint64_t product = uint64_t(h.density_dims[0]) * h.density_dims[1] * h.density_dims[2];
  uint64_t expected = kHeaderBytes + h.payload_bytes;  // sections follow the payloads, back to back
  for (int id = 0; id < int(kSectionCount); ++id) {
    const Section& s = h.sections[id];
    const char* what = kSectionNames[id];
    if (s.offset != expected)
      return make_error(Errc::range, "{}: field sections[{}].offset at byte {}: {} section at byte {}, expected {}", name, id,
                        section_field_offset(id, offsetof(Section, offset)), what, s.offset, expected);
    if (s.bytes > file_bytes - s.offset)
      return make_error(Errc::range, "{}: field sections[{}].bytes at byte {}: {} section of {} bytes at byte {} runs past the end of the {}-byte file",
                        name, id, section_field_offset(id, offsetof(Section, bytes)), what, s.bytes, s.offset, file_bytes);
    expected = s.offset + s.bytes;
  }
  if (h.flags & kFlagCell) {  // the cell section, after the occupancy section
    const Section& c = h.cell;
    if (c.offset != expected)
      return make_error(Errc::range, "{}: field cell.offset at byte {}: cell section at byte {}, expected {}", name,
                        offsetof(FileHeader, cell) + offsetof(Section, offset), c.offset, expected);
    if (c.bytes != sizeof(CellRecord) || c.raw_bytes != c.bytes)
      return make_error(Errc::format, "{}: field cell.bytes at byte {}: cell section has {} bytes ({} decoded), expected {}",
                        name, offsetof(FileHeader, cell) + offsetof(Section, bytes), c.bytes, c.raw_bytes,
                        sizeof(CellRecord));
    if (c.bytes > file_bytes - c.offset)
      return make_error(Errc::range, "{}: field cell.bytes at byte {}: cell section of {} bytes at byte {} runs past the end of the {}-byte file",
                        name, offsetof(FileHeader, cell) + offsetof(Section, bytes), c.bytes, c.offset, file_bytes);
    expected = c.offset + c.bytes;
  }
  if (h.flags & kFlagPropertyHistogram) {  // the property histograms, last
    const Section& p = h.property_histograms;
    const uint64_t want = uint64_t(h.node_count) * sizeof(PropertyHistogram);
    if (p.offset != expected)
      return make_error(Errc::range, "{}: field property_histograms.offset at byte {}: property histogram section at byte "
                        "{}, expected {}", name, HFIELD(property_histograms) + offsetof(Section, offset), p.offset, expected);
    if (p.bytes != want || p.raw_bytes != p.bytes)
      return make_error(Errc::format, "{}: field property_histograms.bytes at byte {}: property histogram section has {} "
                        "bytes ({} decoded), expected {} (node_count * 64)", name,
                        HFIELD(property_histograms) + offsetof(Section, bytes), p.bytes, p.raw_bytes, want);
    if (p.bytes > file_bytes - p.offset)
      return make_error(Errc::range, "{}: field property_histograms.bytes at byte {}: property histogram section of {} "
                        "bytes at byte {} runs past the end of the {}-byte file", name,
                        HFIELD(property_histograms) + offsetof(Section, bytes), p.bytes, p.offset, file_bytes);
    expected = p.offset + p.bytes;
  }
  if (expected != file_bytes)
    return make_error(Errc::format, "{}: {} bytes after the last section at byte {} (file has {} bytes)", name,
                      file_bytes - expected, expected, file_bytes);
  auto size_error = [&](int id, uint64_t want, const char* why) {
    return make_error(Errc::format, "{}: field sections[{}].bytes at byte {}: {} section has {} bytes, expected {} ({})", name,
                      id, section_field_offset(id, offsetof(Section, bytes)), kSectionNames[id], h.sections[id].bytes,
                      want, why);
  };
  const Section& st = h.sections[kSectionTypes];
  if (st.bytes != uint64_t(h.type_count) * sizeof(TypeEntry) || st.raw_bytes != st.bytes)
    return size_error(kSectionTypes, uint64_t(h.type_count) * sizeof(TypeEntry), "type_count * 64");
  const Section& sd = h.sections[kSectionDirectory];
  if (sd.bytes != uint64_t(h.node_count) * sizeof(NodeEntry) || sd.raw_bytes != sd.bytes)
    return size_error(kSectionDirectory, uint64_t(h.node_count) * sizeof(NodeEntry), "node_count * 112");
  const Section& sv = h.sections[kSectionVoxels];
  const uint64_t refs = sv.raw_bytes / sizeof(VoxelRef);
  if (sv.raw_bytes % sizeof(VoxelRef) != 0 || refs > h.particle_count || refs > kMaxVoxelRefs)
    return make_error(Errc::format,
                      "{}: field sections[2].raw_bytes at byte {}: voxel lists decode to {} bytes (must be 8 * refs, at most "
                      "one ref per particle and {} refs)",
                      name, section_field_offset(kSectionVoxels, offsetof(Section, raw_bytes)), sv.raw_bytes, kMaxVoxelRefs);
  if (refs == 0 ? sv.bytes != 0
                : (sv.bytes == 0 || sv.bytes > uint64_t(LZ4_compressBound(int(sv.raw_bytes))) ||
                   sv.raw_bytes > lz4_max_decoded(sv.bytes)))
    return size_error(kSectionVoxels, refs == 0 ? 0 : uint64_t(LZ4_compressBound(int(sv.raw_bytes))),
                      "an LZ4 block of the voxel lists");
  const Section& sn = h.sections[kSectionDensity];
  if (sn.raw_bytes != 4 * product)
    return make_error(Errc::format, "{}: field sections[3].raw_bytes at byte {}: density volume decodes to {} bytes, dims give {}",
                      name, section_field_offset(kSectionDensity, offsetof(Section, raw_bytes)), sn.raw_bytes, 4 * product);
  if (product == 0 ? sn.bytes != 0
                   : (sn.bytes == 0 || sn.bytes > uint64_t(LZ4_compressBound(int(4 * product))) ||
                      sn.raw_bytes > lz4_max_decoded(sn.bytes)))
    return size_error(kSectionDensity, product == 0 ? 0 : uint64_t(LZ4_compressBound(int(4 * product))),
                      "an LZ4 block of the density counts");
  const Section& so = h.sections[kSectionOccupancy];
  if (so.bytes != uint64_t(h.node_count) * kOccupancyBytes || so.raw_bytes != so.bytes)
    return size_error(kSectionOccupancy, uint64_t(h.node_count) * kOccupancyBytes, "node_count * 64");
  return {};
}

Status StoreReader::Impl::read_section(int id, void* dst) {
  const Section& s = header.sections[id];
  if (s.bytes == 0) {
    if (hash_bytes({}) != s.hash)
      return make_error(Errc::checksum, "{}: {} section at byte {}: checksum mismatch", name, kSectionNames[id], s.offset);
    return {};
  }
  MDS_TRY(file.pread_all(dst, static_cast<size_t>(s.bytes), s.offset));
  if (hash_bytes({static_cast<const uint8_t*>(dst), static_cast<size_t>(s.bytes)}) != s.hash)
    return make_error(Errc::checksum, "{}: {} section at byte {}: checksum mismatch", name, kSectionNames[id], s.offset);
  return {};
}

Status StoreReader::Impl::check_types() {
  const uint64_t base = header.sections[kSectionTypes].offset;
  uint64_t total = 0;
  for (size_t t = 0; t < types.size(); ++t) {
    const TypeEntry& e = types[t];
    const uint64_t at = base + t * sizeof(TypeEntry);
    if (!std::isfinite(e.radius) || e.radius < 0)
      return make_error(Errc::range, "{}: type {} at byte {}: radius {} is not finite and non-negative", name, t, at, e.radius);
    if (std::memchr(e.name, 0, sizeof(e.name)) == nullptr)
      return make_error(Errc::format, "{}: type {} at byte {}: name is not NUL-terminated", name, t,
                        at + offsetof(TypeEntry, name));
    if (e.particle_count > header.particle_count - total)
      return make_error(Errc::range, "{}: type {} at byte {}: particle counts of the types exceed the store's {}", name, t,
                        at + offsetof(TypeEntry, particle_count), header.particle_count);
    total += e.particle_count;
  }
  if (total != header.particle_count)
    return make_error(Errc::range, "{}: type table at byte {}: type particle counts sum to {}, header says {}", name, base,
                      total, header.particle_count);
  return {};
}

Status StoreReader::Impl::check_directory() {
  const FileHeader& h = header;
  const bool grid = h.density_dims[0] != 0;
  const uint64_t base = h.sections[kSectionDirectory].offset;
  const uint64_t voxel_refs = voxels.size();
  uint64_t offset = kHeaderBytes, particles = 0, meshlets = 0, voxel_next = 0, raw_total = 0;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const NodeEntry& e = nodes[i];
    const uint64_t at = base + i * sizeof(NodeEntry);
    auto bad = [&](Errc c, size_t field, const char* fname, const std::string& why) {
      return make_error(c, "{}: node {} field {} at byte {}: {}", name, i, fname, at + field, why);
    };
#define NODE_ERR(c, f, ...) bad(c, offsetof(NodeEntry, f), #f, fmt::format(__VA_ARGS__))
    if (e.reserved != 0) return NODE_ERR(Errc::format, reserved, "not zero");
    if (e.particle_count < 1 || e.particle_count > h.node_size_max)
      return NODE_ERR(Errc::range, particle_count, "{} outside [1, node_size_max={}]", e.particle_count, h.node_size_max);
    if (e.meshlet_count < 1 || e.meshlet_count > e.particle_count)
      return NODE_ERR(Errc::range, meshlet_count, "{} outside [1, {}]", e.meshlet_count, e.particle_count);
    if (uint64_t(e.meshlet_count) * h.meshlet_size_max < e.particle_count)
      return NODE_ERR(Errc::range, meshlet_count, "{} meshlets of at most {} cannot hold {} particles", e.meshlet_count,
                      h.meshlet_size_max, e.particle_count);
    if (e.payload_offset != offset)
      return NODE_ERR(Errc::range, payload_offset, "payload at byte {}, expected {} (payloads are contiguous in node order)",
                      e.payload_offset, offset);
    const uint64_t raw = e.payload_raw_bytes;
    const uint64_t raw_min = node_payload_fixed_bytes(e.particle_count, e.meshlet_count, h.flags);
    const uint64_t raw_max = node_payload_max_bytes(e.particle_count, e.meshlet_count, h.flags);
    if (raw < raw_min || raw > raw_max)
      return NODE_ERR(Errc::format, payload_raw_bytes, "{} outside [{}, {}] for {} particles and {} meshlets", raw, raw_min,
                      raw_max, e.particle_count, e.meshlet_count);
    if (e.payload_bytes < 1 || e.payload_bytes > uint64_t(LZ4_compressBound(int(raw))) ||
        raw > lz4_max_decoded(e.payload_bytes))
      return NODE_ERR(Errc::range, payload_bytes, "{} is not a valid LZ4 block size for {} decoded bytes", e.payload_bytes, raw);
    if (e.payload_bytes > kHeaderBytes + h.payload_bytes - offset)
      return NODE_ERR(Errc::range, payload_bytes, "payload [{}, {}) runs past the payload area ending at byte {}", offset,
                      offset + e.payload_bytes, kHeaderBytes + h.payload_bytes);
    if (e.first_particle != particles)
      return NODE_ERR(Errc::range, first_particle, "{}, expected prefix sum {}", e.first_particle, particles);
    if (e.first_meshlet != meshlets)
      return NODE_ERR(Errc::range, first_meshlet, "{}, expected prefix sum {}", e.first_meshlet, meshlets);
    if (!finite3(e.center_min) || !finite3(e.center_max))
      return NODE_ERR(Errc::range, center_min, "quantization frame is not finite");
    for (int a = 0; a < 3; ++a)
      if (e.center_min[a] > e.center_max[a]) return NODE_ERR(Errc::range, center_min, "min > max on axis {}", a);
    if (!std::isfinite(e.max_radius) || e.max_radius < 0)
      return NODE_ERR(Errc::range, max_radius, "{} is not finite and non-negative", e.max_radius);
    if (e.voxel_first != voxel_next)
      return NODE_ERR(Errc::range, voxel_first, "{}, expected prefix sum {}", e.voxel_first, voxel_next);
    if (grid ? (e.voxel_count < 1 || e.voxel_count > e.particle_count) : e.voxel_count != 0)
      return NODE_ERR(Errc::range, voxel_count, "{} voxel refs for {} particles{}", e.voxel_count, e.particle_count,
                      grid ? "" : " without a density grid");
    if (e.voxel_count > voxel_refs - voxel_next)
      return NODE_ERR(Errc::range, voxel_count, "voxel refs [{}, {}) run past the {} refs in the voxel section",
                      e.voxel_first, voxel_next + e.voxel_count, voxel_refs);
#undef NODE_ERR
    offset += e.payload_bytes;
    particles += e.particle_count;
    meshlets += e.meshlet_count;
    voxel_next += e.voxel_count;
    raw_total += e.payload_raw_bytes;
  }
  if (offset != kHeaderBytes + h.payload_bytes)
    return make_error(Errc::range, "{}: field payload_bytes at byte {}: node payloads end at byte {}, header says {}", name,
                      HFIELD(payload_bytes), offset, kHeaderBytes + h.payload_bytes);
  if (raw_total != h.payload_raw_bytes)
    return make_error(Errc::range, "{}: field payload_raw_bytes at byte {}: nodes sum to {}, header says {}", name,
                      HFIELD(payload_raw_bytes), raw_total, h.payload_raw_bytes);
  if (particles != h.particle_count)
    return make_error(Errc::range, "{}: field particle_count at byte {}: nodes sum to {}, header says {}", name,
                      HFIELD(particle_count), particles, h.particle_count);
  if (meshlets != h.meshlet_count)
    return make_error(Errc::range, "{}: field meshlet_count at byte {}: nodes sum to {}, header says {}", name,
                      HFIELD(meshlet_count), meshlets, h.meshlet_count);
  if (voxel_next != voxel_refs)
    return make_error(Errc::range, "{}: voxel lists section at byte {}: holds {} refs, nodes use {}", name,
                      h.sections[kSectionVoxels].offset, voxel_refs, voxel_next);
  return {};
}

Status StoreReader::Impl::check_voxels_and_density(std::span<const uint8_t> block) {
  const FileHeader& h = header;
  const uint64_t product = uint64_t(h.density_dims[0]) * h.density_dims[1] * h.density_dims[2];
  const uint64_t vbase = h.sections[kSectionVoxels].offset;
  if (product == 0) return {};
  const uint64_t dbase = h.sections[kSectionDensity].offset;
  density.resize(product);  // product <= 2^28 and <= 255 * section bytes (checked)
  Status st = decode_density_section(block, density);
  if (!st.ok()) return make_error(st.error().code, "{}: density volume at byte {}: {}", name, dbase, st.error().message);
  // Each node's refs: strictly ascending voxel indices inside the grid, counts summing to the
  // node's particle count; subtracting all refs from the density volume must leave zero.
  for (size_t i = 0; i < nodes.size(); ++i) {
    const NodeEntry& e = nodes[i];
    uint64_t sum = 0;
    for (uint32_t k = 0; k < e.voxel_count; ++k) {
      const uint64_t j = uint64_t(e.voxel_first) + k;
      const VoxelRef& v = voxels[j];
      const uint64_t at = vbase + j * sizeof(VoxelRef);
      if (v.voxel >= product)
        return make_error(Errc::range, "{}: node {} voxel ref {} at byte {}: voxel {} outside the {}x{}x{} grid", name, i, j,
                          at, v.voxel, h.density_dims[0], h.density_dims[1], h.density_dims[2]);
      if (k > 0 && v.voxel <= voxels[j - 1].voxel)
        return make_error(Errc::format, "{}: node {} voxel ref {} at byte {}: voxel indices not strictly ascending", name, i, j, at);
      if (v.count < 1 || v.count > e.particle_count - sum)
        return make_error(Errc::range, "{}: node {} voxel ref {} at byte {}: count {} (node has {} particles, {} used)", name, i,
                          j, at + 4, v.count, e.particle_count, sum);
      sum += v.count;
      if (density[v.voxel] < v.count)
        return make_error(Errc::range, "{}: node {} voxel ref {} at byte {}: voxel {} refs exceed the density volume's count",
                          name, i, j, at, v.voxel);
      density[v.voxel] -= v.count;
    }
    if (sum != e.particle_count)
      return make_error(Errc::range, "{}: node {} at byte {}: voxel ref counts sum to {}, node has {} particles", name, i,
                        h.sections[kSectionDirectory].offset + i * sizeof(NodeEntry), sum, e.particle_count);
  }
  for (uint64_t v = 0; v < product; ++v)
    if (density[v] != 0)
      return make_error(Errc::range, "{}: density volume at byte {}: voxel {} counts {} particles that no node's voxel list holds",
                        name, dbase, v, density[v]);
  for (const VoxelRef& v : voxels) density[v.voxel] += v.count;
  return {};
}

Result<std::unique_ptr<StoreReader>> StoreReader::open(const std::filesystem::path& path) {
  if (is_series_path(path)) {
    // A series index where one store is wanted (bench, stress): say which stores it lists.
    auto series = read_series(path);
    return make_error(Errc::invalid_argument, "{}: a store series index, not a store: this command takes one of "
                      "its stores{} (render, view, info and export take the index)", path.string(),
                      series.ok() ? fmt::format(", e.g. {}", series->frames.front().path.string()) : std::string());
  }
  std::unique_ptr<StoreReader> r(new StoreReader());
  r->impl_ = std::make_unique<Impl>();
  Impl& s = *r->impl_;
  s.path = path;
  s.name = path.string();
  MDS_ASSIGN_OR_RETURN(s.file, File::open_read(path));
  MDS_ASSIGN_OR_RETURN(s.file_bytes, s.file.size());
  if (s.file_bytes < kHeaderBytes)
    return make_error(Errc::format, "{}: file has {} bytes, smaller than the {}-byte header", s.name, s.file_bytes, kHeaderBytes);
  MDS_TRY(s.file.pread_all(&s.header, sizeof(FileHeader), 0));
  MDS_TRY(s.check_header());
  MDS_TRY(s.check_sections());
  // Section sizes are now bounded by the file size.
  const FileHeader& h = s.header;
  s.types.resize(h.type_count);
  MDS_TRY(s.read_section(kSectionTypes, s.types.data()));
  s.nodes.resize(h.node_count);
  MDS_TRY(s.read_section(kSectionDirectory, s.nodes.data()));
  {
    // raw_bytes <= 255 * bytes + 16 and bytes <= file size (checked).
    std::vector<uint8_t> block(h.sections[kSectionVoxels].bytes);
    MDS_TRY(s.read_section(kSectionVoxels, block.data()));
    s.voxels.resize(h.sections[kSectionVoxels].raw_bytes / sizeof(VoxelRef));
    Status st = decode_voxel_section(block, s.voxels);
    if (!st.ok())
      return make_error(st.error().code, "{}: voxel lists at byte {}: {}", s.name, h.sections[kSectionVoxels].offset,
                        st.error().message);
  }
  std::vector<uint8_t> density_block(h.sections[kSectionDensity].bytes);
  MDS_TRY(s.read_section(kSectionDensity, density_block.data()));
  s.occupancy.resize(h.sections[kSectionOccupancy].bytes);
  MDS_TRY(s.read_section(kSectionOccupancy, s.occupancy.data()));
  for (uint32_t i = 0; i < h.node_count; ++i) {
    const uint8_t* rec = s.occupancy.data() + uint64_t(i) * kOccupancyBytes;
    if (std::all_of(rec, rec + kOccupancyBytes, [](uint8_t b) { return b == 0; }))
      return make_error(Errc::format, "{}: node {} occupancy at byte {}: no cell occupied", s.name, i,
                        h.sections[kSectionOccupancy].offset + uint64_t(i) * kOccupancyBytes);
  }
  if (h.flags & kFlagCell) {
    CellRecord rec{};
    MDS_TRY(s.file.pread_all(&rec, sizeof(rec), h.cell.offset));
    if (hash_bytes({reinterpret_cast<const uint8_t*>(&rec), sizeof(rec)}) != h.cell.hash)
      return make_error(Errc::checksum, "{}: cell section at byte {}: checksum mismatch", s.name, h.cell.offset);
    auto cell = decode_cell(rec);
    if (!cell.ok())
      return make_error(cell.error().code, "{}: cell section at byte {}: {}", s.name, h.cell.offset, cell.error().message);
    s.cell = *cell;
  }
  if (h.flags & kFlagPropertyHistogram) {
    const Section& p = h.property_histograms;
    s.histograms.resize(h.node_count);  // bytes == 64 * node_count <= file size (checked)
    MDS_TRY(s.file.pread_all(s.histograms.data(), static_cast<size_t>(p.bytes), p.offset));
    if (hash_bytes({reinterpret_cast<const uint8_t*>(s.histograms.data()), static_cast<size_t>(p.bytes)}) != p.hash)
      return make_error(Errc::checksum, "{}: property histogram section at byte {}: checksum mismatch", s.name, p.offset);
  }
  MDS_TRY(s.check_types());
  MDS_TRY(s.check_directory());
  for (uint32_t i = 0; i < s.histograms.size(); ++i) {
    Status st = check_property_histogram(s.histograms[i], s.nodes[i].particle_count);
    if (!st.ok())
      return make_error(Errc::format, "{}: node {} property histogram at byte {}: {}", s.name, i,
                        h.property_histograms.offset + uint64_t(i) * sizeof(PropertyHistogram), st.error().message);
  }
  MDS_TRY(s.check_voxels_and_density(density_block));
  return r;
}

StoreReader::~StoreReader() = default;
const std::filesystem::path& StoreReader::path() const { return impl_->path; }
const FileHeader& StoreReader::header() const { return impl_->header; }
uint64_t StoreReader::file_bytes() const { return impl_->file_bytes; }
std::span<const TypeEntry> StoreReader::types() const { return impl_->types; }
std::span<const NodeEntry> StoreReader::nodes() const { return impl_->nodes; }
std::span<const uint32_t> StoreReader::density_counts() const { return impl_->density; }
const std::optional<SimulationCell>& StoreReader::cell() const { return impl_->cell; }

std::span<const PropertyHistogram> StoreReader::property_histograms() const { return impl_->histograms; }

std::span<const uint8_t> StoreReader::occupancy(uint32_t node) const {
  if (node >= impl_->nodes.size()) return {};
  return std::span<const uint8_t>(impl_->occupancy).subspan(uint64_t(node) * kOccupancyBytes, kOccupancyBytes);
}

std::span<const VoxelRef> StoreReader::voxels(uint32_t node) const {
  if (node >= impl_->nodes.size()) return {};
  const NodeEntry& e = impl_->nodes[node];
  return std::span<const VoxelRef>(impl_->voxels).subspan(e.voxel_first, e.voxel_count);
}

Status StoreReader::read_payload(uint32_t i, std::vector<uint8_t>& out) const {
  const Impl& s = *impl_;
  if (i >= s.nodes.size())
    return make_error(Errc::invalid_argument, "{}: node {} does not exist ({} nodes)", s.name, i, s.nodes.size());
  const NodeEntry& e = s.nodes[i];
  out.resize(e.payload_bytes);
  Status st = s.file.pread_all(out.data(), out.size(), e.payload_offset);
  if (!st.ok())
    return make_error(st.error().code, "{}: node {} payload at byte {}: {}", s.name, i, e.payload_offset, st.error().message);
  if (hash_bytes(out) != e.payload_hash)
    return make_error(Errc::checksum, "{}: node {} payload at byte {}: checksum mismatch", s.name, i, e.payload_offset);
  return {};
}

Status StoreReader::decode_payload(uint32_t i, std::span<const uint8_t> compressed, NodeData& out) const {
  const Impl& s = *impl_;
  if (i >= s.nodes.size())
    return make_error(Errc::invalid_argument, "{}: node {} does not exist ({} nodes)", s.name, i, s.nodes.size());
  const NodeEntry& e = s.nodes[i];
  const uint64_t at = e.payload_offset;
  if (compressed.size() != e.payload_bytes)
    return make_error(Errc::invalid_argument, "{}: node {} payload at byte {}: got {} compressed bytes, directory says {}",
                      s.name, i, at, compressed.size(), e.payload_bytes);
  thread_local std::vector<uint8_t> raw;
  raw.resize(e.payload_raw_bytes);
  int got = LZ4_decompress_safe(reinterpret_cast<const char*>(compressed.data()), reinterpret_cast<char*>(raw.data()),
                                static_cast<int>(compressed.size()), static_cast<int>(raw.size()));
  if (got != static_cast<int>(raw.size()))
    return make_error(Errc::format, "{}: node {} payload at byte {}: LZ4 block is corrupt (decoded {} of {} bytes)", s.name, i,
                      at, got, raw.size());
  const PayloadLimits lim{e.particle_count, e.meshlet_count, s.header.flags,
                          s.header.type_count, s.header.meshlet_size_max};
  Status st = decode_payload_raw(raw, lim, out);
  if (!st.ok()) return make_error(st.error().code, "{}: node {} payload at byte {}: {}", s.name, i, at, st.error().message);
  return {};
}

Status StoreReader::verify_occupancy(uint32_t i, const NodeData& node) const {
  const Impl& s = *impl_;
  if (i >= s.nodes.size())
    return make_error(Errc::invalid_argument, "{}: node {} does not exist ({} nodes)", s.name, i, s.nodes.size());
  const NodeEntry& e = s.nodes[i];
  if (node.qpos.size() != 3 * uint64_t(e.particle_count))
    return make_error(Errc::invalid_argument, "{}: node {}: {} decoded positions, the node has {} particles", s.name, i,
                      node.qpos.size() / 3, e.particle_count);
  const culling::FineOccupancy need =
      culling::fine_occupancy_of_quantized(e.center_min, e.center_max, double(e.max_radius), node.qpos);
  const uint64_t at = s.header.sections[kSectionOccupancy].offset + uint64_t(i) * kOccupancyBytes;
  const uint8_t* rec = s.occupancy.data() + uint64_t(i) * kOccupancyBytes;
  for (uint32_t c = 0; c < kOccupancyBytes; ++c)
    if (need[c] & ~rec[c])
      return make_error(Errc::format,
                        "{}: node {} occupancy at byte {}: byte {} lacks bits {:#04x} that the node's particles reach",
                        s.name, i, at, c, unsigned(need[c] & ~rec[c]));
  return {};
}

Status StoreReader::verify_property_histogram(uint32_t i, const NodeData& node) const {
  const Impl& s = *impl_;
  if (s.histograms.empty()) return {};
  if (i >= s.nodes.size())
    return make_error(Errc::invalid_argument, "{}: node {} does not exist ({} nodes)", s.name, i, s.nodes.size());
  if (node.property_q.size() != s.nodes[i].particle_count)
    return make_error(Errc::invalid_argument, "{}: node {}: {} decoded property values, the node has {} particles", s.name,
                      i, node.property_q.size(), s.nodes[i].particle_count);
  const PropertyHistogram want = make_property_histogram(node.property_q);
  const PropertyHistogram& got = s.histograms[i];
  const uint64_t at = s.header.property_histograms.offset + uint64_t(i) * sizeof(PropertyHistogram);
  if (want.q_min != got.q_min || want.q_max != got.q_max)
    return make_error(Errc::format, "{}: node {} property histogram at byte {}: range [{}, {}], the node's values span [{}, {}]",
                      s.name, i, at, got.q_min, got.q_max, want.q_min, want.q_max);
  for (uint32_t b = 0; b < kPropertyBins; ++b)
    if (want.counts[b] != got.counts[b])
      return make_error(Errc::format, "{}: node {} property histogram at byte {}: bin {} counts {}, the node has {} there",
                        s.name, i, at + 4 + 2 * b, b, got.counts[b], want.counts[b]);
  return {};
}

Status StoreReader::read_node(uint32_t i, NodeData& out, std::vector<uint8_t>& scratch) const {
  MDS_TRY(read_payload(i, scratch));
  return decode_payload(i, scratch, out);
}

}  // namespace mds::store
