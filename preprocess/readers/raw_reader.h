// Raw particle reader: a headerless file of little-endian float32 (x, y, z) triples,
// 12 bytes per particle, all of type 1. No signature: only chosen with InputFormat::raw
// (or a .raw/.f32 extension as the last resort of detect_format).
#pragma once

#include <vector>

#include "readers/binary_file.h"
#include "readers/reader.h"

namespace mds {

class RawReader final : public ParticleReader {
 public:
  static Result<std::unique_ptr<ParticleReader>> open(const std::filesystem::path& path, const ReaderOptions& options);

  const FrameInfo& info() const override { return info_; }
  Result<size_t> read(ParticleBatch& out, size_t max_particles) override;

 private:
  explicit RawReader(BinaryFile file) : file_(std::move(file)) {}
  BinaryFile file_;
  FrameInfo info_;
  uint64_t next_ = 0;             // index of the next particle to read
  std::vector<float> buffer_;
};

}  // namespace mds
