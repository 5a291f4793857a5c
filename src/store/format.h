// The mdstream store (.mds), format version 2: on-disk structs.
// docs/store-format.md describes every byte in prose; this header is the single definition
// the writer, the reader and (later) the GPU upload code share. All integers little-endian.
//
// File layout:
//   [FileHeader, 512 bytes]           offset 0
//   [node payloads]                   one LZ4 block per node, back to back, from offset 512
//   [section: type table]             TypeEntry[type_count]                 (uncompressed)
//   [section: node directory]         NodeEntry[node_count]                 (uncompressed)
//   [section: voxel lists]            LZ4 block of VoxelRef[sum of NodeEntry::voxel_count] (delta + byte planes)
//   [section: density volume]         LZ4 block of uint32 counts[dims.x*dims.y*dims.z] (byte planes)
//   [section: occupancy]              uint8 occupancy[node_count][64]        (uncompressed; since version 2)
//   [section: cell]                   CellRecord                             (with kFlagCell)
//   [section: property histograms]    PropertyHistogram[node_count]          (with kFlagPropertyHistogram)
// Every section and every payload carries an XXH3-64 hash of its stored bytes; the header
// carries an XXH3-64 hash of itself (computed with header_hash = 0).
#pragma once

#include <cstddef>
#include <cstdint>

namespace mds::store {

inline constexpr char kMagic[8] = {'M', 'D', 'S', 'T', 'O', 'R', 'E', '\0'};
inline constexpr uint32_t kFormatVersion = 2;  // 2: the occupancy section
inline constexpr uint32_t kHeaderBytes = 512;

inline constexpr uint32_t kMaxNodeParticles = 65535;   // per-node indices fit in uint16
inline constexpr uint32_t kMaxMeshletParticles = 255;  // meshlet sizes are uint8
inline constexpr uint32_t kMaxTypes = 256;             // type indices are uint8
inline constexpr uint32_t kQuantMax = 65535;           // 16-bit quantization: q in [0, 65535]

enum HeaderFlags : uint32_t {
  kFlagPerParticleRadius = 1u << 0,  // node payloads carry uint16 radius_q[n]
  kFlagProperty = 1u << 1,           // node payloads carry uint16 property_q[n] (one scalar per particle)
  kFlagColor = 1u << 2,              // node payloads carry uint32 color[n] (RGBA8 per particle, R in bits 0-7)
  kFlagCell = 1u << 3,               // the cell section follows the occupancy section (FileHeader::cell, CellRecord)
  // Only with kFlagProperty: the file ends with one PropertyHistogram per node
  // (FileHeader::property_histograms), after the cell section where there is one.
  kFlagPropertyHistogram = 1u << 4,
};
inline constexpr uint32_t kKnownFlags =
    kFlagPerParticleRadius | kFlagProperty | kFlagColor | kFlagCell | kFlagPropertyHistogram;
inline constexpr uint32_t kPropertyNameBytes = 48;  // FileHeader::property_name, NUL-terminated

enum SectionId : uint32_t {
  kSectionTypes = 0,
  kSectionDirectory = 1,
  kSectionVoxels = 2,
  kSectionDensity = 3,
  kSectionOccupancy = 4,
  kSectionCount = 5,
};

struct Section {
  uint64_t offset;     // byte offset of the stored bytes in the file
  uint64_t bytes;      // stored size (compressed for the voxel lists and the density volume)
  uint64_t raw_bytes;  // decoded size (== bytes for uncompressed sections)
  uint64_t hash;       // XXH3-64 of the stored bytes
};
static_assert(sizeof(Section) == 32);

struct FileHeader {
  char magic[8];                  // kMagic
  uint32_t version;               // kFormatVersion
  uint32_t header_bytes;          // kHeaderBytes
  uint32_t flags;                 // HeaderFlags
  uint32_t node_size_max;         // build parameter --node-size
  uint32_t meshlet_size_max;      // build parameter --meshlet-size
  uint32_t node_count;
  uint64_t particle_count;
  uint64_t meshlet_count;
  uint32_t type_count;
  uint32_t density_dims[3];       // voxels along x, y, z
  double bounds_min[3];           // bounds of particle centres (all nodes)
  double bounds_max[3];
  double density_min[3];          // world-space box covered by the density grid
  double density_max[3];
  float radius_min;               // smallest particle radius in the store
  float radius_max;               // largest; per-particle radius_q maps to [radius_min, radius_max]
  double max_quantization_error;  // max |x_decoded - x_input| over all particles and axes
  double max_error_over_half_step;// max of |error| / (step/2) over axes with step > 0; <= 1
  uint64_t payload_bytes;         // sum of compressed node payloads
  uint64_t payload_raw_bytes;     // sum of decoded node payloads
  Section sections[kSectionCount];
  // With kFlagProperty: the per-particle scalar the payloads carry (e.g. a LAMMPS column "c_pe"),
  // v = property_min + q * (property_max - property_min) / 65535. All zero without the flag.
  char property_name[kPropertyNameBytes];  // NUL-terminated, non-empty with the flag
  float property_min;             // smallest value of the property in the store (finite)
  float property_max;             // largest (finite, >= property_min)
  // With kFlagCell: the cell section (one CellRecord, uncompressed) right after the occupancy
  // section. All zero without the flag.
  Section cell;
  // With kFlagPropertyHistogram: PropertyHistogram[node_count] (uncompressed) at the end of the
  // file, right after the cell section (or the occupancy section without a cell). All zero without.
  Section property_histograms;
  uint8_t reserved[24];           // zero
  uint64_t header_hash;           // XXH3-64 of these 512 bytes with header_hash = 0
};
static_assert(sizeof(FileHeader) == kHeaderBytes);
static_assert(offsetof(FileHeader, sections) == 200);
static_assert(offsetof(FileHeader, property_name) == 360);
static_assert(offsetof(FileHeader, property_min) == 408);
static_assert(offsetof(FileHeader, cell) == 416);
static_assert(offsetof(FileHeader, property_histograms) == 448);
static_assert(offsetof(FileHeader, reserved) == 480);
static_assert(offsetof(FileHeader, header_hash) == 504);

// The simulation cell (core/cell.h) as stored: x = origin + f0 a + f1 b + f2 c, f in [0, 1].
struct CellRecord {
  double origin[3];      // finite
  double vectors[3][3];  // rows a, b, c (finite; a zero vector is a flat cell)
  uint32_t periodic;     // bit d: periodic along vector d; bits 3..31 zero
  uint32_t reserved[7];  // zero
};
static_assert(sizeof(CellRecord) == 128);
static_assert(offsetof(CellRecord, vectors) == 24);
static_assert(offsetof(CellRecord, periodic) == 96);



// One entry per type (particle species). Type indices in payloads refer to this table.
struct TypeEntry {
  int32_t input_id;          // the id the input used (LAMMPS type, species index, MMPLD list)
  float radius;              // radius of this type (per-particle radius overrides when present)
  uint64_t particle_count;
  char name[48];             // NUL-terminated species name, or empty
};
static_assert(sizeof(TypeEntry) == 64);

// One entry per node. Nodes are stored in Morton order of their centres.
struct NodeEntry {
  uint64_t payload_offset;     // file offset of the LZ4 block
  uint32_t payload_bytes;      // compressed size
  uint32_t payload_raw_bytes;  // decoded size, in [node_payload_fixed_bytes, node_payload_max_bytes]
  uint64_t payload_hash;       // XXH3-64 of the compressed bytes
  uint32_t particle_count;     // 1..node_size_max
  uint32_t meshlet_count;      // 1..particle_count
  uint64_t first_particle;     // global index of this node's first particle (prefix sum)
  uint64_t first_meshlet;      // global index of this node's first meshlet (prefix sum)
  double center_min[3];        // quantization frame: x = center_min + q * step,
  double center_max[3];        //   step = (center_max - center_min) / 65535 (0 if degenerate)
  float max_radius;            // largest radius in the node: culling bounds = centre bounds +- max_radius
  uint32_t voxel_first;        // first VoxelRef of this node in the voxel-list section
  uint32_t voxel_count;        // number of density voxels this node's particles fall in
  uint32_t reserved;           // zero
};
static_assert(sizeof(NodeEntry) == 112);

// Occupancy section: per node, 8^3 = 512 bits = 64 bytes saying which cells of its culling box
// [center_min - max_radius, center_max + max_radius] (cut into 8 equal parts per axis) a sphere of
// the node reaches into (centres as decoded, each grown by max_radius). Byte c = i + 4 (j + 4 k),
// i, j, k in [0, 4), holds the 2^3 cells (2i + si, 2j + sj, 2k + sk) as bit si + 2 sj + 4 sk
// (src/culling/node_occupancy.h). The renderer classifies a node that is not loaded by its
// occupied cells (docs/streaming.md, "Sub-node occupancy"); a node has at least one bit set.
inline constexpr uint32_t kOccupancyBytes = 64;  // per node: 512 cells, one bit each

// Property histogram section (kFlagPropertyHistogram): per node, the range of its quantized
// property values and how many of its particles fall into each of kPropertyBins equal parts of
// that range (store/property_histogram.h has the bin rule). A streaming renderer decides from it,
// without reading payloads, which nodes a --threshold leaves out, keeps whole, or keeps a share
// of (docs/streaming.md, "Thresholds").
inline constexpr uint32_t kPropertyBins = 30;  // 2 + 2 + 30 * 2 = 64 bytes per node (0.1 % of a 10000-particle node)
struct PropertyHistogram {
  uint16_t q_min;                  // smallest property_q of the node
  uint16_t q_max;                  // largest (>= q_min)
  uint16_t counts[kPropertyBins];  // particles per bin; sum = the node's particle_count (<= 65535)
};
static_assert(sizeof(PropertyHistogram) == 64);

// A density voxel touched by a node, and how many of the node's particles it holds.
// Subtracting a node's VoxelRefs from the density volume removes that node (paper 000, §4.4).
struct VoxelRef {
  uint32_t voxel;   // x + dims.x * (y + dims.y * z)
  uint32_t count;   // particles of this node whose centre lies in that voxel
};
static_assert(sizeof(VoxelRef) == 8);

// Decoded node payload layout (before LZ4), n particles, m meshlets, particles in meshlet order.
// Positions are stored per meshlet as offsets from the meshlet's smallest quantized coordinate,
// bit-packed with a per-meshlet, per-axis bit width (the offsets of 16 spatially close particles
// need ~13 instead of 16 bits, and LZ4 alone finds almost nothing in 16-bit coordinates); type
// indices likewise as offsets from the meshlet's smallest type. docs/results/store-layout.md
// has the measurements behind this choice. Arrays, back to back, no padding:
//   uint8  meshlet_size[m]        m bytes   1..meshlet_size_max, sum == n
//   uint16 meshlet_base[3][m]     6m bytes  plane per axis: smallest qpos of the meshlet on x, y, z
//   uint16 meshlet_bits[m]        2m bytes  bits 0-4 / 5-9 / 10-14: width of the x / y / z offsets,
//                                           each 0..16; bit 15 zero
//   uint8  meshlet_type_base[m]   m bytes   smallest type index of the meshlet
//   uint8  meshlet_type_bits[m]   m bytes   width of the type offsets, 0..8
//   uint16 radius_q[n]            2n bytes  only with kFlagPerParticleRadius:
//                                           r = radius_min + q * (radius_max - radius_min) / 65535
//   uint16 property_q[n]          2n bytes  only with kFlagProperty:
//                                           v = property_min + q * (property_max - property_min) / 65535
//   uint32 color[n]               4n bytes  only with kFlagColor: RGBA8, R in bits 0-7 (little-endian
//                                           bytes R, G, B, A); sRGB as the input gave it
//   uint8  bits[]                 the rest  bit stream, LSB first: for each meshlet j in order, the x
//                                           offsets of its particles (wx bits each), then y, then z,
//                                           then the type offsets (wt bits each); zero-padded to a byte
// qpos[k][a] = meshlet_base[a][j] + offset (must be <= 65535); type = type_base[j] + offset.
inline constexpr uint32_t kMaxAxisBits = 16;
inline constexpr uint32_t kMaxTypeBits = 8;
// Size of everything before the bit stream; flags = the header's (the per-particle arrays).
inline constexpr uint64_t node_payload_fixed_bytes(uint64_t n, uint64_t m, uint32_t flags) {
  return 11 * m + ((flags & kFlagPerParticleRadius) ? 2 * n : 0) + ((flags & kFlagProperty) ? 2 * n : 0) +
         ((flags & kFlagColor) ? 4 * n : 0);
}
// Largest decoded payload: full-width offsets (3 * 16 + 8 bits per particle).
inline constexpr uint64_t node_payload_max_bytes(uint64_t n, uint64_t m, uint32_t flags) {
  return node_payload_fixed_bytes(n, m, flags) + 7 * n;
}

// The property value of a quantized property_q (kFlagProperty), in double: the one decoding
// formula (export, the renderer's colour mapping and the tests use it).
inline double property_value(float property_min, float property_max, uint16_t q) {
  return double(property_min) + double(q) * (double(property_max) - double(property_min)) / kQuantMax;
}

// Voxel-list section (decoded size 8 * R for R refs), before LZ4: byte planes of
//   uint32 delta[R]  = voxel[i] - voxel[i-1] (mod 2^32, voxel[-1] = 0), then of uint32 count[R];
// plane b of an array holds byte b (little-endian) of every element. Density volume, before LZ4:
// the 4 byte planes of uint32 counts[dims product]. Both are single LZ4 blocks, so a store holds
// at most kMaxVoxelRefs voxel refs.
inline constexpr uint64_t kMaxVoxelRefs = 0x7E000000ull / 8;  // LZ4_MAX_INPUT_SIZE / 8

}  // namespace mds::store
