// Building blocks of the synthetic scenes, each producing an exact number of particles in
// independent chunks (so that chunks can be generated in parallel and written in order):
//  - LatticeRegion: sites of an FCC lattice (nearest-neighbour distance 1) inside a region,
//    enumerated row by row with optional carving, cut at an exact particle budget;
//  - ScatterPart: independent samples (gas), particle i a pure function of (seed, i);
//  - BlobPart: compact clusters (droplets, protein spikes, RNA lumps), each made of exactly
//    n lattice sites: the n sites nearest to the blob's shape under a shape metric.
// Per-frame motion: thermal jitter redrawn per frame (bounded Irwin-Hall noise) plus, for
// gas and clusters, a constant drift per frame.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "core/result.h"
#include "synth/synth.h"
#include "synth/synth_random.h"

namespace mds::synth {

constexpr double kFccStep = 0.70710678118654752;     // half the cubic lattice constant (a = sqrt 2)
constexpr double kFccDensity = 1.4142135623730951;   // sites per unit volume
constexpr uint64_t kChunkTarget = uint64_t{1} << 16; // particles per generated chunk

// Particles of one chunk, one frame, before formatting.
struct Buffer {
  std::vector<double> x, y, z;
  std::vector<uint8_t> cls;
  void clear() { x.clear(); y.clear(); z.clear(); cls.clear(); }
  size_t size() const { return x.size(); }
  void push(double px, double py, double pz, int c) {
    x.push_back(px); y.push_back(py); z.push_back(pz); cls.push_back(static_cast<uint8_t>(c));
  }
};

struct Chunk {
  uint64_t first = 0;  // 0-based index of the chunk's first particle in the frame (id = index + 1)
  uint64_t count = 0;
  std::function<void(int frame, Buffer& out)> generate;  // appends exactly `count` particles
};

// Thermal displacement of particle `index` in `frame`: bounded, unit variance per axis.
inline void frame_jitter(uint64_t seed, uint64_t index, int frame, double out[3]) {
  uint64_t h = hash64(seed, index, 0x100 + static_cast<uint64_t>(frame));
  bounded_normal3(h, splitmix64(h ^ 0xA5A5A5A5A5A5A5A5ull), splitmix64(h ^ 0x5A5A5A5A5A5A5A5Aull), out);
}

// Frame-independent random key of particle `index` (type choice, class noise).
inline uint64_t particle_key(uint64_t seed, uint64_t index) { return hash64(seed, index, 7); }

struct XSpan { double lo, hi; };  // half-open world-x interval [lo, hi)

class LatticeRegion : public std::enable_shared_from_this<LatticeRegion> {
 public:
  struct Params {
    double origin[3] = {0, 0, 0};  // world position of site index (0, 0, 0)
    int64_t n[3] = {0, 0, 0};      // index extents; sites (ix, iy, iz) with ix+iy+iz even, spacing kFccStep
    // x-intervals of the row at (y, z), sorted and disjoint, appended to `spans` (given
    // empty); null = the whole row.
    std::function<void(double y, double z, std::vector<XSpan>& spans)> row_spans;
    std::function<bool(double x, double y, double z)> keep;              // null = keep every site
    std::function<int(double x, double y, double z, uint64_t key)> classify;  // null = class 0
    std::function<double(double x, double y, double z)> sigma;           // null = sigma_const
    double sigma_const = 0.04;
    uint64_t budget = 0;       // particles wanted, in row order (rows: iz outer, iy inner)
    bool allow_fewer = false;  // else an error when the region holds fewer sites than the budget
  };

  // Counts sites row by row until the budget is reached.
  static Result<std::shared_ptr<const LatticeRegion>> create(Params p, uint64_t seed, int threads);

  uint64_t count() const { return count_; }
  double top_z() const { return top_z_; }  // world z of the highest plane that holds particles
  void append_chunks(uint64_t first, std::vector<Chunk>& out) const;

  template <class F>
  void for_each_site_in_row(int64_t iy, int64_t iz, F&& f) const;

 private:
  Params p_;
  uint64_t seed_ = 0;
  std::vector<uint32_t> row_counts_;  // rows used, each full except possibly the last
  uint64_t last_row_take_ = 0;        // sites taken from the last row
  uint64_t count_ = 0;
  double top_z_ = 0;
  void generate(uint64_t row0, uint64_t row1, uint64_t first, int frame, Buffer& out) const;
};

class ScatterPart : public std::enable_shared_from_this<ScatterPart> {
 public:
  // Base position, drift per frame and class of particle i (0-based within the part);
  // `s` is a stream keyed by (seed, salt, i).
  using Sampler = std::function<int(uint64_t i, Stream& s, double pos[3], double vel[3])>;
  static std::shared_ptr<const ScatterPart> create(uint64_t count, uint64_t seed, uint64_t salt, Sampler sampler);
  uint64_t count() const { return count_; }
  void append_chunks(uint64_t first, std::vector<Chunk>& out) const;

 private:
  uint64_t count_ = 0, seed_ = 0, salt_ = 0;
  Sampler sampler_;
};

struct Blob {
  enum class Kind { lumpy_sphere, spike };
  Kind kind = Kind::lumpy_sphere;
  uint64_t n = 0;              // exact particle count
  double center[3] = {0, 0, 0};  // sphere centre, or spike base
  double axis[3] = {0, 0, 1};    // spike direction (unit)
  double length = 0;             // spike length
  double r_stalk = 1, r_head = 2;  // spike radii (stalk, head)
  double lump = 0.25;            // lumpy sphere: relative amplitude of the surface bumps
  double vel[3] = {0, 0, 0};     // drift per frame
  double sigma = 0.08;           // thermal jitter
  int cls = 0;
  uint64_t key = 0;              // shape randomness (bump directions, lattice orientation)
};

class BlobPart : public std::enable_shared_from_this<BlobPart> {
 public:
  static std::shared_ptr<const BlobPart> create(std::vector<Blob> blobs, uint64_t seed);
  uint64_t count() const { return count_; }
  const std::vector<Blob>& blobs() const { return blobs_; }
  void append_chunks(uint64_t first, std::vector<Chunk>& out) const;
  // The blob's particles (base positions, frame 0 without jitter), appended to xyz.
  static void sites(const Blob& b, std::vector<double>& xyz);

 private:
  std::vector<Blob> blobs_;
  uint64_t count_ = 0, seed_ = 0;
};

// Runs fn(i) for i in [0, n) on `threads` threads (contiguous blocks).
void parallel_for(uint64_t n, int threads, const std::function<void(uint64_t)>& fn);

// Number of worker threads for `requested` (0 = hardware concurrency).
int resolve_threads(int requested);

// ---- template implementation ----

template <class F>
void LatticeRegion::for_each_site_in_row(int64_t iy, int64_t iz, F&& f) const {
  const double y = p_.origin[1] + static_cast<double>(iy) * kFccStep;
  const double z = p_.origin[2] + static_cast<double>(iz) * kFccStep;
  thread_local std::vector<XSpan> spans;
  spans.clear();
  if (p_.row_spans) {
    p_.row_spans(y, z, spans);
  } else {
    spans.push_back({-1e300, 1e300});
  }
  for (size_t s = 0; s < spans.size(); ++s) {
    double lo = (spans[s].lo - p_.origin[0]) / kFccStep, hi = (spans[s].hi - p_.origin[0]) / kFccStep;
    int64_t ix0 = lo < 0 ? 0 : static_cast<int64_t>(std::ceil(lo));
    int64_t ix1 = hi > static_cast<double>(p_.n[0]) ? p_.n[0] : static_cast<int64_t>(std::ceil(hi));  // exclusive
    if (ix0 >= ix1) continue;
    if (((ix0 + iy + iz) & 1) != 0) ++ix0;
    for (int64_t ix = ix0; ix < ix1; ix += 2) {
      const double x = p_.origin[0] + static_cast<double>(ix) * kFccStep;
      if (p_.keep && !p_.keep(x, y, z)) continue;
      if (!f(x, y, z)) return;
    }
  }
}

}  // namespace mds::synth
