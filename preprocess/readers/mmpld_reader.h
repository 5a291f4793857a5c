// MMPLD (MegaMol particle list data) reader, file versions 100-103 (1.0-1.3).
//
// Layout (checked against MegaMol's MMPLDDataSource.cpp and the VISUS mmpld library):
//   header : char magic[6] = "MMPLD\0", uint16 version, uint32 frame count,
//            float bbox[6], float clipbox[6], uint64 frame offsets[frames + 1]
//   frame  : (version >= 102: float timestamp), uint32 list count, lists
//   list   : uint8 vertex type, uint8 colour type,
//            float global radius        if vertex type is FLOAT_XYZ, SHORT_XYZ or DOUBLE_XYZ,
//            uint8 global colour[4]     if colour type is NONE,
//            float intensity range[2]   if colour type is FLOAT_I or DOUBLE_I,
//            uint64 particle count,
//            (version 103: float list bbox[6]),
//            count x (vertex data + colour data) interleaved,
//            (version 101: uint32 cluster count, uint64 cluster data size, cluster data)
//   vertex types: 0 NONE (0 B), 1 FLOAT_XYZ (12), 2 FLOAT_XYZR (16), 3 SHORT_XYZ (3 x int16, 6),
//                 4 DOUBLE_XYZ (24)
//   colour types: 0 NONE (0), 1 UINT8_RGB (3), 2 UINT8_RGBA (4), 3 FLOAT_I (4), 4 FLOAT_RGB (12),
//                 5 FLOAT_RGBA (16), 6 USHORT_RGBA (8), 7 DOUBLE_I (8)
// A list with vertex type NONE carries no per-particle data and is skipped.
//
// Mapping to mdstream: type id = list index + 1; a list's global radius goes to
// FrameInfo::type_radius; FLOAT_XYZR radii go to ParticleBatch::radius (lists without
// per-particle radius then get their global radius there). Colours are skipped, except the
// FLOAT_I / DOUBLE_I intensities with ReaderOptions::property "intensity", and the RGB(A)
// colours with ReaderOptions::color (a NONE list's global colour for each of its particles;
// float channels clamped to [0, 1], USHORT ones scaled to 8 bits; RGB gets alpha 255). SHORT_XYZ
// coordinates are returned as their raw int16 values. The file is treated as hostile:
// every offset and count is checked against the frame and file size before use.
#pragma once

#include <vector>

#include "readers/binary_file.h"
#include "readers/reader.h"

namespace mds {

struct MmpldList {
  uint8_t vertex_type = 0;
  uint8_t colour_type = 0;
  float global_radius = 0;
  bool has_global_radius = false;
  uint32_t global_colour = 0;  // colour type NONE: the list's RGBA8 (pack_rgba8)
  float intensity_range[2] = {0, 0};  // colour types FLOAT_I, DOUBLE_I: the list's (min, max), as written
  uint64_t count = 0;
  uint64_t data_offset = 0;   // absolute byte offset of the first particle
  uint32_t stride = 0;        // bytes per particle (vertex + colour)
  uint32_t vertex_size = 0;
};

class MmpldReader final : public ParticleReader {
 public:
  static Result<std::unique_ptr<ParticleReader>> open(const std::filesystem::path& path, const ReaderOptions& options);

  const FrameInfo& info() const override { return info_; }
  Result<size_t> read(ParticleBatch& out, size_t max_particles) override;

  uint16_t version() const { return version_; }
  uint32_t frame_count() const { return frame_count_; }
  const std::vector<MmpldList>& lists() const { return lists_; }

 private:
  explicit MmpldReader(BinaryFile file) : file_(std::move(file)) {}
  Status parse_frame(uint64_t begin, uint64_t end, bool with_timestamp);
  // The RGBA8 of the particle whose colour bytes are p (file offset `at`) in list l.
  Result<uint32_t> colour(const MmpldList& l, const unsigned char* p, uint64_t at, uint64_t index) const;

  BinaryFile file_;
  FrameInfo info_;
  uint16_t version_ = 0;
  uint32_t frame_count_ = 0;
  std::vector<MmpldList> lists_;
  size_t cur_list_ = 0;        // list being streamed
  uint64_t cur_index_ = 0;     // next particle within it
  std::vector<unsigned char> buffer_;
  bool intensity_ = false;  // ReaderOptions::property "intensity": FLOAT_I / DOUBLE_I colours kept as the property
  bool colour_ = false;     // ReaderOptions::color: RGB(A) colours kept as ParticleBatch::color
};

}  // namespace mds
