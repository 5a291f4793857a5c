// Morton sort of float xyz positions with the positions moved along (see xyz_sort.h).
#include "convert/xyz_sort.h"

#include <immintrin.h>

#include <algorithm>
#include <atomic>
#include <barrier>
#include <bit>
#include <cstring>
#include <thread>
#include <vector>

#include "convert/radix_sort.h"

namespace mds::convert {

namespace {

constexpr int kDigitBits = 11;
constexpr size_t kBuckets = size_t(1) << kDigitBits;
constexpr size_t kMinParallel = size_t(1) << 16;

struct MagicKey {
  const MortonGrid* g;
  uint64_t operator()(const float* p) const { return g->key(p[0], p[1], p[2]); }
};

// morton_encode with BMI2: bit i of x -> 3i, y -> 3i+1, z -> 3i+2 (cells are < 2^21). The cells
// of x and y in one SSE2 vector: clamping (c, 0, kMortonAxisMax) before truncating gives
// MortonGrid::cell's value for every c (max_pd(c, 0) is 0 for NaN and for c <= 0, as !(c > 0)).
struct PdepKey {
  explicit PdepKey(const MortonGrid* g)
      : lo_xy(_mm_setr_pd(g->lo(0), g->lo(1))),
        lo_z(_mm_set_sd(g->lo(2))),
        sc_xy(_mm_setr_pd(g->scale(0), g->scale(1))),
        sc_z(_mm_set_sd(g->scale(2))),
        top(_mm_set1_pd(double(kMortonAxisMax))) {}
  __m128d lo_xy, lo_z, sc_xy, sc_z, top;
  __attribute__((target("bmi2"))) uint64_t operator()(const float* p) const {
    const __m128d zero = _mm_setzero_pd();
    const __m128d xy = _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
    const __m128d z = _mm_cvtss_sd(zero, _mm_load_ss(p + 2));
    const __m128i c_xy = _mm_cvttpd_epi32(_mm_min_pd(_mm_max_pd(_mm_mul_pd(_mm_sub_pd(xy, lo_xy), sc_xy), zero), top));
    const uint32_t cz = uint32_t(_mm_cvttsd_si32(_mm_min_sd(_mm_max_sd(_mm_mul_sd(_mm_sub_sd(z, lo_z), sc_z), zero), top)));
    const uint32_t cx = uint32_t(_mm_cvtsi128_si32(c_xy)), cy = uint32_t(_mm_cvtsi128_si32(_mm_srli_si128(c_xy, 4)));
    return _pdep_u64(cx, 0x1249249249249249ull) | _pdep_u64(cy, 0x2492492492492492ull) |
           _pdep_u64(cz, 0x4924924924924924ull);
  }
};

template <class KeyFn>
inline void histogram_impl(const float* xyz, size_t b, size_t e, int shift, KeyFn key, uint32_t* h) {
  for (size_t i = b; i < e; ++i) ++h[(key(xyz + 3 * i) >> shift) & (kBuckets - 1)];
}

template <class KeyFn>
inline void scatter_impl(const float* xyz, size_t b, size_t e, int shift, KeyFn key, uint32_t* pos, float* xs) {
  for (size_t i = b; i < e; ++i) {
    const float* p = xyz + 3 * i;
    const uint32_t to = pos[(key(p) >> shift) & (kBuckets - 1)]++;
    std::memcpy(xs + 3 * size_t(to), p, 12);
  }
}

template <class KeyFn>
inline void keys_impl(const float* xyz, size_t n, KeyFn key, uint64_t* keys) {
  for (size_t i = 0; i < n; ++i) keys[i] = key(xyz + 3 * i);
}

void histogram_magic(const float* xyz, size_t b, size_t e, int shift, const MortonGrid* g, uint32_t* h) {
  histogram_impl(xyz, b, e, shift, MagicKey{g}, h);
}
void scatter_magic(const float* xyz, size_t b, size_t e, int shift, const MortonGrid* g, uint32_t* pos, float* xs) {
  scatter_impl(xyz, b, e, shift, MagicKey{g}, pos, xs);
}
void keys_magic(const float* xyz, size_t n, const MortonGrid* g, uint64_t* keys) { keys_impl(xyz, n, MagicKey{g}, keys); }
__attribute__((target("bmi2"), flatten)) void histogram_pdep(const float* xyz, size_t b, size_t e, int shift,
                                                             const MortonGrid* g, uint32_t* h) {
  histogram_impl(xyz, b, e, shift, PdepKey(g), h);
}
__attribute__((target("bmi2"), flatten)) void scatter_pdep(const float* xyz, size_t b, size_t e, int shift,
                                                           const MortonGrid* g, uint32_t* pos, float* xs) {
  scatter_impl(xyz, b, e, shift, PdepKey(g), pos, xs);
}
__attribute__((target("bmi2"), flatten)) void keys_pdep(const float* xyz, size_t n, const MortonGrid* g,
                                                        uint64_t* keys) {
  keys_impl(xyz, n, PdepKey(g), keys);
}

const bool kHavePdep = __builtin_cpu_supports("bmi2");

// Per-thread scratch of the bucket sorts.
struct BucketScratch {
  std::vector<uint64_t> k, kt;
  std::vector<uint32_t> idx, it;
  std::vector<float> xs;
};

// Sorts the m positions of one bucket in place by key (their keys computed here: the sort
// stores no keys).
void sort_bucket(float* xyz, size_t m, const MortonGrid& grid, BucketScratch& s) {
  if (m < 2) return;
  if (s.idx.size() < m) {
    s.k.resize(m);
    s.kt.resize(m);
    s.idx.resize(m);
    s.it.resize(m);
    s.xs.resize(3 * m);
  }
  uint64_t* keys = s.k.data();
  morton_keys_of_xyz(xyz, m, grid, keys);
  bool sorted = true;
  for (size_t j = 1; j < m && sorted; ++j) sorted = keys[j - 1] <= keys[j];
  if (sorted) return;
  for (size_t j = 0; j < m; ++j) s.idx[j] = uint32_t(j);
  radix_sort_pairs_serial(keys, s.idx.data(), s.kt.data(), s.it.data(), m);
  float* xs = s.xs.data();
  for (size_t j = 0; j < m; ++j) std::memcpy(xs + 3 * j, xyz + 3 * size_t(s.idx[j]), 12);
  std::memcpy(xyz, xs, 12 * m);
}

}  // namespace

void morton_keys_of_xyz(const float* xyz, size_t n, const MortonGrid& grid, uint64_t* keys) {
  if (kHavePdep) keys_pdep(xyz, n, &grid, keys);
  else keys_magic(xyz, n, &grid, keys);
}

void sort_xyz_by_key(const float* xyz, size_t n, const MortonGrid& grid, unsigned threads, float* xyz_sorted) {
  if (n == 0) return;
  // The top digit ends at the highest bit any key can have (that of the bounds' far corner).
  const uint64_t top = grid.key(grid.hi(0), grid.hi(1), grid.hi(2));
  const int shift = std::max(0, int(std::bit_width(top)) - kDigitBits);
  const bool pdep = kHavePdep;
  threads = std::max(1u, n < kMinParallel ? 1u : threads);

  std::vector<std::vector<uint32_t>> hist(threads, std::vector<uint32_t>(kBuckets, 0));
  std::vector<uint32_t> bucket_begin(kBuckets + 1, 0);
  auto plan_offsets = [&]() noexcept { histograms_to_offsets(hist, bucket_begin, kBuckets); };
  std::barrier sync_offsets(std::ptrdiff_t(threads), plan_offsets);
  std::barrier sync_scatter{std::ptrdiff_t(threads)};
  std::atomic<size_t> next_bucket{0};

  auto worker = [&](unsigned t) {
    const size_t b = n * t / threads, e = n * (t + 1) / threads;
    uint32_t* h = hist[t].data();
    if (pdep) histogram_pdep(xyz, b, e, shift, &grid, h);
    else histogram_magic(xyz, b, e, shift, &grid, h);
    sync_offsets.arrive_and_wait();
    if (pdep) scatter_pdep(xyz, b, e, shift, &grid, h, xyz_sorted);
    else scatter_magic(xyz, b, e, shift, &grid, h, xyz_sorted);
    sync_scatter.arrive_and_wait();
    BucketScratch scratch;
    for (;;) {
      const size_t d = next_bucket.fetch_add(1);
      if (d >= kBuckets) break;
      const size_t lo = bucket_begin[d], m = bucket_begin[d + 1] - lo;
      sort_bucket(xyz_sorted + 3 * lo, m, grid, scratch);
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(worker, t);
  worker(0);
  for (auto& th : pool) th.join();
}

}  // namespace mds::convert
