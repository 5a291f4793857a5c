// Raw float32 xyz reader (see raw_reader.h). Streams in batches with pread.
#include "readers/raw_reader.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "readers/reader_factories.h"

namespace mds {

static_assert(std::endian::native == std::endian::little, "raw reader assumes a little-endian host");

namespace {
constexpr uint64_t kBytesPerParticle = 12;
constexpr size_t kMaxChunkParticles = size_t{1} << 20;  // bounded buffer: 12 MiB
}  // namespace

Result<std::unique_ptr<ParticleReader>> RawReader::open(const std::filesystem::path& path,
                                                        const ReaderOptions& options) {
  if (options.frame != 0 && options.frame != -1) {
    return make_error(Errc::invalid_argument, "{}: raw files hold one frame; frame {} requested", path.string(),
                      options.frame);
  }
  MDS_ASSIGN_OR_RETURN(BinaryFile file, BinaryFile::open(path));
  if (file.size() % kBytesPerParticle != 0) {
    return make_error(Errc::format,
                      "{}: raw float32 xyz file size {} bytes is not a multiple of 12 (3 x float32 per particle)",
                      path.string(), file.size());
  }
  std::unique_ptr<RawReader> r(new RawReader(std::move(file)));
  r->info_.particle_count = r->file_.size() / kBytesPerParticle;
  r->info_.frame_count = 1;
  return std::unique_ptr<ParticleReader>(std::move(r));
}

Result<size_t> RawReader::read(ParticleBatch& out, size_t max_particles) {
  out.clear();
  const uint64_t remaining = info_.particle_count - next_;
  const size_t n = static_cast<size_t>(std::min<uint64_t>({remaining, max_particles, kMaxChunkParticles}));
  if (n == 0) return size_t{0};
  buffer_.resize(n * 3);
  const uint64_t offset = next_ * kBytesPerParticle;
  MDS_TRY(file_.read_at(offset, buffer_.data(), n * kBytesPerParticle, "particle coordinates"));
  out.x.resize(n);
  out.y.resize(n);
  out.z.resize(n);
  out.type.assign(n, 1);
  for (size_t i = 0; i < n; ++i) {
    const float* p = &buffer_[3 * i];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) return non_finite_error(p, next_ + i);
    out.x[i] = p[0];
    out.y[i] = p[1];
    out.z[i] = p[2];
  }
  next_ += n;
  return n;
}

Error RawReader::non_finite_error(const float* p, uint64_t particle) const {
  const int bad = !std::isfinite(p[0]) ? 0 : (!std::isfinite(p[1]) ? 1 : 2);
  return make_error(Errc::range, "{}: byte offset {}: particle {} has a non-finite coordinate ({})", file_.name(),
                    particle * kBytesPerParticle + 4 * bad, particle, p[bad]);
}

Error RawReader::non_finite_error(uint64_t particle) const {
  float p[3] = {0, 0, 0};
  if (auto st = file_.read_at(particle * kBytesPerParticle, p, sizeof p, "particle coordinates"); !st.ok())
    return st.error();
  return non_finite_error(p, particle);
}

Result<std::span<const float>> RawReader::map_coordinates() {
  if (!mapping_.data()) {
    MDS_ASSIGN_OR_RETURN(mapping_, FileMapping::map(file_));
  }
  return std::span<const float>(static_cast<const float*>(mapping_.data()), size_t(info_.particle_count) * 3);
}

Result<std::unique_ptr<ParticleReader>> open_raw_reader(const std::filesystem::path& path,
                                                        const ReaderOptions& options) {
  return RawReader::open(path, options);
}

}  // namespace mds
