// Periodic images of the particles (see replicate_reader.h).
#include "readers/replicate_reader.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <vector>

namespace mds {

Result<ReplicateCounts> parse_replicate_counts(const std::string& text) {
  ReplicateCounts c{};
  const char* p = text.data();
  const char* end = p + text.size();
  for (int a = 0; a < 3; ++a) {
    if (a > 0) {
      if (p == end || (*p != ',' && *p != 'x')) break;
      ++p;
    }
    const auto [q, ec] = std::from_chars(p, end, c[a]);
    if (ec != std::errc() || q == p || c[a] < 1 || c[a] > 65536)
      return make_error(Errc::invalid_argument,
                        "--replicate '{}': expected three image counts NA,NB,NC (or NAxNBxNC), each 1..65536", text);
    p = q;
    if (a == 2 && p == end) return c;
  }
  return make_error(Errc::invalid_argument,
                    "--replicate '{}': expected three image counts NA,NB,NC (or NAxNBxNC), each 1..65536", text);
}

SimulationCell replicated_cell(const SimulationCell& cell, const ReplicateCounts& counts) {
  SimulationCell r = cell;
  for (int v = 0; v < 3; ++v)
    for (int k = 0; k < 3; ++k) r.vectors[v][k] = cell.vectors[v][k] * double(counts[v]);
  return r;
}

namespace {

// Particles [begin, end) of `in`, every column it has, into `out` (capacity reused).
template <class V>
void copy_column(const V& in, size_t begin, size_t end, V& out) {
  if (in.empty()) {
    out.clear();
    return;
  }
  out.assign(in.begin() + ptrdiff_t(begin), in.begin() + ptrdiff_t(end));
}
void copy_range(const ParticleBatch& in, size_t begin, size_t end, ParticleBatch& out) {
  copy_column(in.x, begin, end, out.x);
  copy_column(in.y, begin, end, out.y);
  copy_column(in.z, begin, end, out.z);
  copy_column(in.type, begin, end, out.type);
  copy_column(in.radius, begin, end, out.radius);
  copy_column(in.id, begin, end, out.id);
  copy_column(in.property, begin, end, out.property);
  copy_column(in.color, begin, end, out.color);
}

// The volume (3 vectors), area (2) or length (1) the vectors span, against the product of their
// lengths: 0 for linearly dependent ones.
double spanned(const std::vector<const double*>& v) {
  auto len = [](const double* a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); };
  if (v.size() == 1) return len(v[0]) > 0.0 ? 1.0 : 0.0;
  const double* a = v[0];
  const double* b = v[1];
  const double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  double norm = len(a) * len(b);
  if (v.size() == 2) return norm > 0.0 ? len(c) / norm : 0.0;
  norm *= len(v[2]);
  return norm > 0.0 ? std::abs(c[0] * v[2][0] + c[1] * v[2][1] + c[2] * v[2][2]) / norm : 0.0;
}

class ReplicateReader final : public ParticleReader {
 public:
  ReplicateReader(std::unique_ptr<ParticleReader> inner, const ReplicateCounts& counts, std::string file)
      : inner_(std::move(inner)), counts_(counts), info_(inner_->info()), file_(std::move(file)) {
    images_ = uint64_t(counts[0]) * counts[1] * counts[2];
    info_.particle_count *= images_;
    info_.cell = replicated_cell(info_.cell, counts);
    info_.cell.bounds(info_.box_lo, info_.box_hi);
    next_ = images_;  // nothing buffered
  }
  const FrameInfo& info() const override { return info_; }
  Result<size_t> read(ParticleBatch& out, size_t max_particles) override {
    if (next_ == images_) {
      MDS_ASSIGN_OR_RETURN(size_t n, inner_->read(batch_, max_particles));
      if (n == 0) {
        out.clear();
        return size_t{0};
      }
      next_ = 0;
      offset_ = 0;
    }
    const uint64_t image = next_;
    // This call's part of the batch in this image: at most max_particles (a later call may ask
    // for fewer than the batch holds).
    const size_t begin = offset_, end = std::min(batch_.size(), begin + std::max<size_t>(max_particles, 1));
    offset_ = end;
    if (offset_ == batch_.size()) {
      ++next_;
      offset_ = 0;
    }
    const uint64_t i = image % counts_[0], j = image / counts_[0] % counts_[1], k = image / counts_[0] / counts_[1];
    const SimulationCell& c = inner_->info().cell;
    double shift[3];
    for (int a = 0; a < 3; ++a)
      shift[a] = double(i) * c.vectors[0][a] + double(j) * c.vectors[1][a] + double(k) * c.vectors[2][a];
    copy_range(batch_, begin, end, out);
    if (image > 0) {
      bool finite = true;
      for (size_t p = 0; p < out.size(); ++p) {
        out.x[p] += shift[0];
        out.y[p] += shift[1];
        out.z[p] += shift[2];
        finite &= std::isfinite(out.x[p]) && std::isfinite(out.y[p]) && std::isfinite(out.z[p]);
      }
      if (!finite)
        for (size_t p = 0; p < out.size(); ++p)
          if (!std::isfinite(out.x[p]) || !std::isfinite(out.y[p]) || !std::isfinite(out.z[p]))
            return make_error(Errc::range,
                              "{}: --replicate: particle {} of the frame at ({:.17g}, {:.17g}, {:.17g}) leaves the "
                              "range of double in image ({}, {}, {})",
                              file_, done_ + begin + p, batch_.x[begin + p], batch_.y[begin + p],
                              batch_.z[begin + p], i, j, k);
    }
    if (next_ == images_) done_ += batch_.size();
    return out.size();
  }
  std::map<int32_t, std::string> type_names() const override { return inner_->type_names(); }

 private:
  std::unique_ptr<ParticleReader> inner_;
  ReplicateCounts counts_;
  FrameInfo info_;
  std::string file_;
  uint64_t done_ = 0;  // particles of the input before batch_
  uint64_t images_ = 1;
  uint64_t next_ = 0;    // the image of batch_ handed out next; images_: read a new batch
  size_t offset_ = 0;    // where in batch_ that image goes on
  ParticleBatch batch_;  // the input's current batch
};

}  // namespace

Result<std::unique_ptr<ParticleReader>> replicate_reader(std::unique_ptr<ParticleReader> inner,
                                                         const ReplicateCounts& counts, const std::string& file) {
  const FrameInfo& fi = inner->info();
  if (!fi.has_box)
    return make_error(Errc::invalid_argument, "{}: --replicate: the input has no simulation cell to replicate", file);
  if (!fi.cell.finite())
    return make_error(Errc::invalid_argument, "{}: --replicate: the cell is not finite or beyond {:g} ({})", file,
                      SimulationCell::kMaxMagnitude, describe(fi.cell));
  // The vectors with more than one image must be independent, or images would coincide.
  std::vector<const double*> repeated;
  std::string names;
  for (int v = 0; v < 3; ++v) {
    const double* a = fi.cell.vectors[v];
    if (counts[v] > 1 && a[0] == 0.0 && a[1] == 0.0 && a[2] == 0.0)
      return make_error(Errc::invalid_argument,
                        "{}: --replicate: the cell's vector {} has zero length, so its {} images would lie on top of "
                        "each other ({})",
                        file, "abc"[v], counts[v], describe(fi.cell));
    if (counts[v] > 1) {
      repeated.push_back(a);
      names += "abc"[v];
    }
  }
  if (repeated.size() > 1 && !(spanned(repeated) > 1e-12))
    return make_error(Errc::invalid_argument,
                      "{}: --replicate: the cell's vectors {} are {}, so images along them would lie on top of each "
                      "other ({})",
                      file, names, repeated.size() == 2 ? "parallel" : "coplanar", describe(fi.cell));
  if (!replicated_cell(fi.cell, counts).finite())
    return make_error(Errc::invalid_argument, "{}: --replicate {}x{}x{}: the grown cell is beyond {:g} ({})", file,
                      counts[0], counts[1], counts[2], SimulationCell::kMaxMagnitude, describe(fi.cell));
  const uint64_t images = uint64_t(counts[0]) * counts[1] * counts[2];
  if (fi.particle_count > kMaxReplicatedParticles / images)
    return make_error(Errc::range, "{}: --replicate {}x{}x{}: {} particles x {} images is more than {}", file,
                      counts[0], counts[1], counts[2], fi.particle_count, images, kMaxReplicatedParticles);
  return std::unique_ptr<ParticleReader>(std::make_unique<ReplicateReader>(std::move(inner), counts, file));
}

}  // namespace mds
