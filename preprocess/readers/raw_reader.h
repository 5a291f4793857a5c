// Raw particle reader: a headerless file of little-endian float32 (x, y, z) triples,
// 12 bytes per particle, all of type 1. No signature: only chosen with InputFormat::raw
// (or a .raw/.f32 extension as the last resort of detect_format).
#pragma once

#include <span>
#include <vector>

#include "readers/binary_file.h"
#include "readers/reader.h"

namespace mds {

class RawReader final : public ParticleReader {
 public:
  static Result<std::unique_ptr<ParticleReader>> open(const std::filesystem::path& path, const ReaderOptions& options);

  const FrameInfo& info() const override { return info_; }
  Result<size_t> read(ParticleBatch& out, size_t max_particles) override;

  // Bulk access for the converter: the whole file mapped read-only, 3 floats per particle
  // (valid while the reader lives; not validated: see non_finite_error). Independent of read().
  Result<std::span<const float>> map_coordinates();
  // The error read() gives for particle i, whose coordinates are not all finite.
  Error non_finite_error(uint64_t particle) const;

 private:
  explicit RawReader(BinaryFile file) : file_(std::move(file)) {}
  Error non_finite_error(const float* p, uint64_t particle) const;
  BinaryFile file_;
  FrameInfo info_;
  uint64_t next_ = 0;             // index of the next particle to read
  std::vector<float> buffer_;
  FileMapping mapping_;
};

}  // namespace mds
