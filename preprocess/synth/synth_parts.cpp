// Scene building blocks: FCC lattice regions, scattered gas, compact clusters (see synth_parts.h).
#include "synth/synth_parts.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <thread>

namespace mds::synth {

int resolve_threads(int requested) {
  if (requested > 0) return std::min(requested, 64);
  unsigned h = std::thread::hardware_concurrency();
  return h == 0 ? 1 : static_cast<int>(std::min(h, 64u));
}

void parallel_for(uint64_t n, int threads, const std::function<void(uint64_t)>& fn) {
  const uint64_t t = std::min<uint64_t>(static_cast<uint64_t>(std::max(threads, 1)), n);
  if (t <= 1) {
    for (uint64_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::vector<std::thread> pool;
  pool.reserve(t);
  for (uint64_t k = 0; k < t; ++k) {
    pool.emplace_back([&, k] {
      const uint64_t b = n * k / t, e = n * (k + 1) / t;
      for (uint64_t i = b; i < e; ++i) fn(i);
    });
  }
  for (auto& th : pool) th.join();
}

// ---------------------------------------------------------------- LatticeRegion

Result<std::shared_ptr<const LatticeRegion>> LatticeRegion::create(Params p, uint64_t seed, int threads) {
  if (p.n[0] <= 0 || p.n[1] <= 0 || p.n[2] <= 0) {
    if (p.budget == 0 || p.allow_fewer) {
      auto r = std::shared_ptr<LatticeRegion>(new LatticeRegion());
      r->p_ = std::move(p);
      r->seed_ = seed;
      return std::shared_ptr<const LatticeRegion>(std::move(r));
    }
    return make_error(Errc::internal, "synth: empty lattice region for a budget of {} particles", p.budget);
  }
  auto r = std::shared_ptr<LatticeRegion>(new LatticeRegion());
  r->p_ = std::move(p);
  r->seed_ = seed;
  const Params& q = r->p_;
  const uint64_t rows_per_plane = static_cast<uint64_t>(q.n[1]);
  const uint64_t plane_sites = std::max<uint64_t>(1, static_cast<uint64_t>(q.n[0]) * rows_per_plane / 2);
  const uint64_t batch_planes = std::max<uint64_t>(1, (uint64_t{4} << 20) / plane_sites);
  uint64_t total = 0;
  bool done = q.budget == 0;
  std::vector<uint32_t> batch;
  for (int64_t z0 = 0; z0 < q.n[2] && !done; z0 += static_cast<int64_t>(batch_planes)) {
    const int64_t z1 = std::min<int64_t>(q.n[2], z0 + static_cast<int64_t>(batch_planes));
    const uint64_t rows = static_cast<uint64_t>(z1 - z0) * rows_per_plane;
    batch.assign(rows, 0);
    parallel_for(rows, threads, [&](uint64_t i) {
      const int64_t iz = z0 + static_cast<int64_t>(i / rows_per_plane), iy = static_cast<int64_t>(i % rows_per_plane);
      uint32_t c = 0;
      r->for_each_site_in_row(iy, iz, [&](double, double, double) { ++c; return true; });
      batch[i] = c;
    });
    for (uint64_t i = 0; i < rows; ++i) {
      const uint64_t c = batch[i];
      if (total + c >= q.budget) {
        r->row_counts_.push_back(static_cast<uint32_t>(c));
        r->last_row_take_ = q.budget - total;
        total = q.budget;
        if (r->last_row_take_ > 0) r->top_z_ = q.origin[2] + static_cast<double>(z0 + static_cast<int64_t>(i / rows_per_plane)) * kFccStep;
        done = true;
        break;
      }
      r->row_counts_.push_back(static_cast<uint32_t>(c));
      total += c;
      if (c > 0) r->top_z_ = q.origin[2] + static_cast<double>(z0 + static_cast<int64_t>(i / rows_per_plane)) * kFccStep;
    }
  }
  if (!done) {
    if (!q.allow_fewer) {
      return make_error(Errc::internal, "synth: lattice region holds {} sites, fewer than the budget of {}", total, q.budget);
    }
    r->last_row_take_ = r->row_counts_.empty() ? 0 : r->row_counts_.back();
  }
  r->count_ = total;
  return std::shared_ptr<const LatticeRegion>(std::move(r));
}

void LatticeRegion::generate(uint64_t row0, uint64_t row1, uint64_t first, int frame, Buffer& out) const {
  const uint64_t rows_per_plane = static_cast<uint64_t>(p_.n[1]);
  uint64_t index = first;
  for (uint64_t r = row0; r < row1; ++r) {
    uint64_t limit = (r + 1 == row_counts_.size()) ? last_row_take_ : row_counts_[r];
    if (limit == 0) continue;
    uint64_t taken = 0;
    const int64_t iz = static_cast<int64_t>(r / rows_per_plane), iy = static_cast<int64_t>(r % rows_per_plane);
    for_each_site_in_row(iy, iz, [&](double x, double y, double z) {
      double d[3];
      frame_jitter(seed_, index, frame, d);
      const double s = p_.sigma ? p_.sigma(x, y, z) : p_.sigma_const;
      const int c = p_.classify ? p_.classify(x, y, z, particle_key(seed_, index)) : 0;
      out.push(x + s * d[0], y + s * d[1], z + s * d[2], c);
      ++index;
      return ++taken < limit;
    });
  }
}

void LatticeRegion::append_chunks(uint64_t first, std::vector<Chunk>& out) const {
  auto self = shared_from_this();
  uint64_t r0 = 0, acc = 0, start = first;
  const uint64_t nrows = row_counts_.size();
  for (uint64_t r = 0; r < nrows; ++r) {
    acc += (r + 1 == nrows) ? last_row_take_ : row_counts_[r];
    if (acc >= kChunkTarget || r + 1 == nrows) {
      if (acc > 0) {
        const uint64_t a = r0, b = r + 1, f = start;
        out.push_back(Chunk{f, acc, [self, a, b, f](int frame, Buffer& buf) { self->generate(a, b, f, frame, buf); }});
      }
      start += acc;
      acc = 0;
      r0 = r + 1;
    }
  }
}

// ---------------------------------------------------------------- ScatterPart

std::shared_ptr<const ScatterPart> ScatterPart::create(uint64_t count, uint64_t seed, uint64_t salt, Sampler sampler) {
  auto p = std::make_shared<ScatterPart>();
  p->count_ = count;
  p->seed_ = seed;
  p->salt_ = salt;
  p->sampler_ = std::move(sampler);
  return p;
}

void ScatterPart::append_chunks(uint64_t first, std::vector<Chunk>& out) const {
  auto self = shared_from_this();
  for (uint64_t i0 = 0; i0 < count_; i0 += kChunkTarget) {
    const uint64_t i1 = std::min(count_, i0 + kChunkTarget);
    out.push_back(Chunk{first + i0, i1 - i0, [self, i0, i1](int frame, Buffer& buf) {
      for (uint64_t i = i0; i < i1; ++i) {
        Stream s(hash64(self->seed_, self->salt_, i));
        double pos[3], vel[3] = {0, 0, 0};
        const int c = self->sampler_(i, s, pos, vel);
        buf.push(pos[0] + frame * vel[0], pos[1] + frame * vel[1], pos[2] + frame * vel[2], c);
      }
    }});
  }
}

// ---------------------------------------------------------------- BlobPart

std::shared_ptr<const BlobPart> BlobPart::create(std::vector<Blob> blobs, uint64_t seed) {
  auto p = std::make_shared<BlobPart>();
  p->blobs_ = std::move(blobs);
  p->seed_ = seed;
  for (const Blob& b : p->blobs_) p->count_ += b.n;
  return p;
}

namespace {

void cross(const double a[3], const double b[3], double out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

void normalize(double v[3]) {
  const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (l > 0) { v[0] /= l; v[1] /= l; v[2] /= l; }
}

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

struct Candidate {
  double d;
  int32_t iu, iv, iw;
};

}  // namespace

void BlobPart::sites(const Blob& b, std::vector<double>& xyz) {
  Stream s(b.key);
  // Local frame: e3 along the spike axis (or a random direction), e1/e2 randomly rotated around it.
  double e1[3], e2[3], e3[3];
  if (b.kind == Blob::Kind::spike) {
    e3[0] = b.axis[0]; e3[1] = b.axis[1]; e3[2] = b.axis[2];
    normalize(e3);
  } else {
    s.unit_vector(e3);
  }
  double helper[3] = {1, 0, 0};
  if (std::fabs(e3[0]) > 0.8) { helper[0] = 0; helper[1] = 1; }
  cross(e3, helper, e1);
  normalize(e1);
  cross(e3, e1, e2);
  const double ang = s.uniform(0.0, 6.283185307179586), ca = std::cos(ang), sa = std::sin(ang);
  for (int k = 0; k < 3; ++k) {
    const double a = e1[k], c = e2[k];
    e1[k] = ca * a + sa * c;
    e2[k] = -sa * a + ca * c;
  }
  // Surface bumps of lumpy spheres: low-order zonal harmonics (Legendre P2, P3) around random
  // axes, cheap (no transcendental functions) and smooth over the sphere.
  constexpr int kWaves = 5;
  double w[kWaves][3], amp2[kWaves], amp3[kWaves];
  for (int m = 0; m < kWaves; ++m) {
    s.unit_vector(w[m]);
    amp2[m] = s.uniform(-1.0, 1.0);
    amp3[m] = s.uniform(-1.0, 1.0);
  }
  const double r0 = std::cbrt(3.0 * static_cast<double>(b.n) / (4.0 * 3.141592653589793 * kFccDensity));
  auto metric = [&](double u, double v, double wz) {
    if (b.kind == Blob::Kind::spike) {
      const double t = std::clamp(wz / b.length, 0.0, 1.0);
      const double r = b.r_stalk + (b.r_head - b.r_stalk) * smoothstep(0.45, 0.75, t);
      const double ex = wz < 0 ? -3.0 * wz : (wz > b.length ? wz - b.length : 0.0);  // flat foot, round head
      return std::sqrt(u * u + v * v + ex * ex) / r;
    }
    const double len = std::sqrt(u * u + v * v + wz * wz);
    if (len == 0) return 0.0;
    double f = 0;
    for (int m = 0; m < kWaves; ++m) {
      const double c = (u * w[m][0] + v * w[m][1] + wz * w[m][2]) / len;
      f += amp2[m] * (1.5 * c * c - 0.5) + amp3[m] * (2.5 * c * c - 1.5) * c;
    }
    return len / (1.0 + b.lump * std::clamp(f / 2.5, -1.0, 1.0));
  };
  double dcap = b.kind == Blob::Kind::spike ? 1.15 : r0 * 1.1 + 0.8;
  std::vector<Candidate> cand;
  for (;;) {
    double umax, wlo, whi;
    if (b.kind == Blob::Kind::spike) {
      umax = dcap * std::max(b.r_stalk, b.r_head);
      wlo = -dcap * b.r_stalk;
      whi = b.length + dcap * b.r_head;
    } else {
      umax = dcap * (1.0 + b.lump);
      wlo = -umax;
      whi = umax;
    }
    const int32_t ib = static_cast<int32_t>(std::ceil(umax / kFccStep));
    const int32_t w0 = static_cast<int32_t>(std::floor(wlo / kFccStep)), w1 = static_cast<int32_t>(std::ceil(whi / kFccStep));
    cand.clear();
    for (int32_t iw = w0; iw <= w1; ++iw) {
      for (int32_t iv = -ib; iv <= ib; ++iv) {
        for (int32_t iu = -ib; iu <= ib; ++iu) {
          if (((iu + iv + iw) & 1) != 0) continue;
          const double u = iu * kFccStep, v = iv * kFccStep, wz = iw * kFccStep;
          if (b.kind != Blob::Kind::spike && u * u + v * v + wz * wz > umax * umax) continue;
          const double d = metric(u, v, wz);
          if (d <= dcap) cand.push_back({d, iu, iv, iw});
        }
      }
    }
    if (cand.size() >= b.n) break;
    dcap *= 1.2;
  }
  std::sort(cand.begin(), cand.end(), [](const Candidate& a, const Candidate& c) {
    if (a.d != c.d) return a.d < c.d;
    if (a.iw != c.iw) return a.iw < c.iw;
    if (a.iv != c.iv) return a.iv < c.iv;
    return a.iu < c.iu;
  });
  const size_t n = std::min<size_t>(b.n, cand.size());
  for (size_t k = 0; k < n; ++k) {
    const double u = cand[k].iu * kFccStep, v = cand[k].iv * kFccStep, wz = cand[k].iw * kFccStep;
    for (int a = 0; a < 3; ++a) xyz.push_back(b.center[a] + u * e1[a] + v * e2[a] + wz * e3[a]);
  }
}

void BlobPart::append_chunks(uint64_t first, std::vector<Chunk>& out) const {
  auto self = shared_from_this();
  uint64_t b0 = 0, acc = 0, start = first;
  for (uint64_t bi = 0; bi < blobs_.size(); ++bi) {
    acc += blobs_[bi].n;
    if (acc >= kChunkTarget || bi + 1 == blobs_.size()) {
      if (acc > 0) {
        const uint64_t a = b0, e = bi + 1, f = start;
        out.push_back(Chunk{f, acc, [self, a, e, f](int frame, Buffer& buf) {
          std::vector<double> xyz;
          uint64_t index = f;
          for (uint64_t k = a; k < e; ++k) {
            const Blob& b = self->blobs_[k];
            xyz.clear();
            sites(b, xyz);
            for (size_t i = 0; i < b.n; ++i, ++index) {
              double d[3];
              frame_jitter(self->seed_, index, frame, d);
              buf.push(xyz[3 * i] + frame * b.vel[0] + b.sigma * d[0], xyz[3 * i + 1] + frame * b.vel[1] + b.sigma * d[1],
                       xyz[3 * i + 2] + frame * b.vel[2] + b.sigma * d[2], b.cls);
            }
          }
        }});
      }
      start += acc;
      acc = 0;
      b0 = bi + 1;
    }
  }
}

}  // namespace mds::synth
