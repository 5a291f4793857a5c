// Positions wrapped into the periodic simulation cell (see wrap_reader.h).
#include "readers/wrap_reader.h"

#include <cmath>

namespace mds {

Result<CellWrap> CellWrap::make(const SimulationCell& cell, const std::string& file) {
  if (!cell.periodic[0] && !cell.periodic[1] && !cell.periodic[2])
    return make_error(Errc::invalid_argument, "{}: --wrap: the cell is periodic along none of its vectors ({})", file,
                      describe(cell));
  // A = [a b c] (columns): A[k][v] = vectors[v][k].
  double A[3][3];
  for (int k = 0; k < 3; ++k)
    for (int v = 0; v < 3; ++v) A[k][v] = cell.vectors[v][k];
  const double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                     A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                     A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
  auto len = [&](int v) {
    return std::sqrt(cell.vectors[v][0] * cell.vectors[v][0] + cell.vectors[v][1] * cell.vectors[v][1] +
                     cell.vectors[v][2] * cell.vectors[v][2]);
  };
  if (!std::isfinite(det) || std::abs(det) <= 1e-12 * len(0) * len(1) * len(2) || det == 0.0)
    return make_error(Errc::invalid_argument, "{}: --wrap: the cell is flat (its vectors span no volume: {})", file,
                      describe(cell));
  CellWrap w;
  w.cell = cell;
  // Inverse by the adjugate.
  w.inverse[0][0] = (A[1][1] * A[2][2] - A[1][2] * A[2][1]) / det;
  w.inverse[0][1] = (A[0][2] * A[2][1] - A[0][1] * A[2][2]) / det;
  w.inverse[0][2] = (A[0][1] * A[1][2] - A[0][2] * A[1][1]) / det;
  w.inverse[1][0] = (A[1][2] * A[2][0] - A[1][0] * A[2][2]) / det;
  w.inverse[1][1] = (A[0][0] * A[2][2] - A[0][2] * A[2][0]) / det;
  w.inverse[1][2] = (A[0][2] * A[1][0] - A[0][0] * A[1][2]) / det;
  w.inverse[2][0] = (A[1][0] * A[2][1] - A[1][1] * A[2][0]) / det;
  w.inverse[2][1] = (A[0][1] * A[2][0] - A[0][0] * A[2][1]) / det;
  w.inverse[2][2] = (A[0][0] * A[1][1] - A[0][1] * A[1][0]) / det;
  return w;
}

bool CellWrap::apply(double& x, double& y, double& z) const {
  const double r[3] = {x - cell.origin[0], y - cell.origin[1], z - cell.origin[2]};
  double f[3], shift[3] = {0, 0, 0};
  bool moved = false;
  for (int i = 0; i < 3; ++i) {
    f[i] = inverse[i][0] * r[0] + inverse[i][1] * r[1] + inverse[i][2] * r[2];
    if (cell.periodic[i]) {
      shift[i] = std::floor(f[i]);
      if (!(std::abs(shift[i]) <= 0x1p50)) return false;  // also NaN
      moved |= shift[i] != 0.0;
    }
  }
  if (!moved) return true;  // inside already: the position as read, bit for bit
  // x - sum_i shift_i v_i: whole cell vectors subtracted from the position as read.
  x -= shift[0] * cell.vectors[0][0] + shift[1] * cell.vectors[1][0] + shift[2] * cell.vectors[2][0];
  y -= shift[0] * cell.vectors[0][1] + shift[1] * cell.vectors[1][1] + shift[2] * cell.vectors[2][1];
  z -= shift[0] * cell.vectors[0][2] + shift[1] * cell.vectors[1][2] + shift[2] * cell.vectors[2][2];
  return std::isfinite(x) && std::isfinite(y) && std::isfinite(z);
}

namespace {

class WrapReader final : public ParticleReader {
 public:
  WrapReader(std::unique_ptr<ParticleReader> inner, CellWrap wrap, std::string file)
      : inner_(std::move(inner)), wrap_(wrap), file_(std::move(file)) {}
  const FrameInfo& info() const override { return inner_->info(); }
  Result<size_t> read(ParticleBatch& out, size_t max_particles) override {
    MDS_ASSIGN_OR_RETURN(size_t n, inner_->read(out, max_particles));
    for (size_t i = 0; i < out.size(); ++i) {
      const double x = out.x[i], y = out.y[i], z = out.z[i];
      if (!wrap_.apply(out.x[i], out.y[i], out.z[i]))
        return make_error(Errc::range, "{}: --wrap: particle {} of the frame at ({:.17g}, {:.17g}, {:.17g}) lies too many cells "
                          "away to wrap", file_, done_ + i, x, y, z);
    }
    done_ += n;
    return n;
  }
  std::map<int32_t, std::string> type_names() const override { return inner_->type_names(); }

 private:
  std::unique_ptr<ParticleReader> inner_;
  CellWrap wrap_;
  std::string file_;
  uint64_t done_ = 0;  // particles handed out before this batch
};

}  // namespace

Result<std::unique_ptr<ParticleReader>> wrap_reader(std::unique_ptr<ParticleReader> inner, const std::string& file) {
  if (!inner->info().has_box)
    return make_error(Errc::invalid_argument, "{}: --wrap: the input has no simulation cell to wrap into", file);
  MDS_ASSIGN_OR_RETURN(CellWrap w, CellWrap::make(inner->info().cell, file));
  return std::unique_ptr<ParticleReader>(std::make_unique<WrapReader>(std::move(inner), w, file));
}

}  // namespace mds
