// Parallel MSD + LSD radix sort of (key, index) pairs (see radix_sort.h).
#include "convert/radix_sort.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <barrier>
#include <bit>
#include <cstdlib>
#include <cstring>
#include <vector>
#include <thread>

namespace mds::convert {

namespace {

constexpr int kMsdBits = 11;
constexpr size_t kMsdBuckets = size_t(1) << kMsdBits;
constexpr int kLsdBits = 11;
constexpr size_t kLsdBuckets = size_t(1) << kLsdBits;
constexpr size_t kLeafMax = size_t(1) << 15;  // buckets up to this size are finished by LSD passes (cache-sized)
constexpr size_t kSmall = 32;                 // insertion sort below this
constexpr int kMaxLsdPasses = 2;              // more varying digits in a leaf: MSD pass instead
constexpr size_t kMinParallel = size_t(1) << 16;

struct Span {
  uint64_t* k;
  uint32_t* i;
};

uint64_t varying_bits(const uint64_t* k, size_t n) {
  uint64_t o = 0, a = ~uint64_t(0);
  for (size_t j = 0; j < n; ++j) {
    o |= k[j];
    a &= k[j];
  }
  return o ^ a;
}

void insertion_sort(uint64_t* k, uint32_t* idx, size_t n) {
  for (size_t j = 1; j < n; ++j) {
    const uint64_t key = k[j];
    const uint32_t v = idx[j];
    size_t p = j;
    while (p > 0 && k[p - 1] > key) {
      k[p] = k[p - 1];
      idx[p] = idx[p - 1];
      --p;
    }
    k[p] = key;
    idx[p] = v;
  }
}

// The MSD digit window for a range whose varying bits are `varying`: the kMsdBits ending at the
// highest varying bit.
int msd_shift(uint64_t varying) { return std::max(0, int(std::bit_width(varying)) - kMsdBits); }
// Number of LSD digit passes needed for the varying bits.
int lsd_passes(uint64_t varying) {
  int p = 0;
  for (int shift = 0; shift < 64; shift += kLsdBits)
    if ((varying >> shift) & (kLsdBuckets - 1)) ++p;
  return p;
}

// Sorts the n pairs of `a` (result in `a`), using `b` as scratch of the same size.
// Ranges whose varying bits fit in at most kMaxLsdPasses LSD digits are finished by LSD passes;
// otherwise one MSD pass on the highest varying bits (digit width ~log2(n) for small ranges, so
// that the buckets hold a few pairs each and end in insertion sort) and recursion per bucket:
// uniform data of 10M keys take 2 scatter passes instead of 1 MSD + 5 LSD passes.
void sort_range(Span a, Span b, size_t n) {
  if (n <= kSmall) {
    insertion_sort(a.k, a.i, n);
    return;
  }
  const uint64_t varying = varying_bits(a.k, n);
  if (varying == 0) return;
  if (n <= kLeafMax && lsd_passes(varying) <= kMaxLsdPasses) {
    // LSD over the varying digits, ping-pong a <-> b, result copied back to a if needed.
    Span src = a, dst = b;
    bool in_a = true;
    for (int shift = 0; shift < 64; shift += kLsdBits) {
      if (((varying >> shift) & (kLsdBuckets - 1)) == 0) continue;
      uint32_t h[kLsdBuckets] = {};
      for (size_t j = 0; j < n; ++j) ++h[(src.k[j] >> shift) & (kLsdBuckets - 1)];
      uint32_t at = 0;
      for (auto& c : h) {
        const uint32_t x = c;
        c = at;
        at += x;
      }
      for (size_t j = 0; j < n; ++j) {
        const uint32_t to = h[(src.k[j] >> shift) & (kLsdBuckets - 1)]++;
        dst.k[to] = src.k[j];
        dst.i[to] = src.i[j];
      }
      std::swap(src, dst);
      in_a = !in_a;
    }
    if (!in_a) {
      std::memcpy(a.k, b.k, n * sizeof(uint64_t));
      std::memcpy(a.i, b.i, n * sizeof(uint32_t));
    }
    return;
  }
  // One MSD pass a -> b on the highest varying bits, buckets sorted in b (a as scratch), copied back.
  const int bits = n > kLeafMax ? kMsdBits : std::clamp(int(std::bit_width(n)) - 1, 4, kMsdBits);
  const size_t buckets = size_t(1) << bits;
  const uint64_t mask = buckets - 1;
  const int shift = std::max(0, int(std::bit_width(varying)) - bits);
  size_t h[kMsdBuckets + 1];
  std::fill(h, h + buckets + 1, size_t(0));
  for (size_t j = 0; j < n; ++j) ++h[((a.k[j] >> shift) & mask) + 1];
  for (size_t d = 1; d <= buckets; ++d) h[d] += h[d - 1];
  size_t pos[kMsdBuckets];
  std::copy(h, h + buckets, pos);
  for (size_t j = 0; j < n; ++j) {
    const size_t to = pos[(a.k[j] >> shift) & mask]++;
    b.k[to] = a.k[j];
    b.i[to] = a.i[j];
  }
  for (size_t d = 0; d < buckets; ++d) {
    const size_t lo = h[d], m = h[d + 1] - h[d];
    if (m > 1) sort_range(Span{b.k + lo, b.i + lo}, Span{a.k + lo, a.i + lo}, m);
  }
  std::memcpy(a.k, b.k, n * sizeof(uint64_t));
  std::memcpy(a.i, b.i, n * sizeof(uint32_t));
}

}  // namespace

void radix_sort_pairs_serial(uint64_t* keys, uint32_t* idx, uint64_t* keys_tmp, uint32_t* idx_tmp, size_t n) {
  if (n < 2) return;
  sort_range(Span{keys, idx}, Span{keys_tmp, idx_tmp}, n);
}

void radix_sort_pairs(std::span<uint64_t> keys, std::span<uint32_t> idx, std::span<uint64_t> keys_tmp,
                      std::span<uint32_t> idx_tmp, unsigned threads) {
  const size_t n = keys.size();
  if (n < 2) return;
  if (idx.size() != n || keys_tmp.size() != n || idx_tmp.size() != n) std::abort();  // caller bug
  threads = std::max(1u, threads);
  if (n < kMinParallel) threads = 1;
  Span a{keys.data(), idx.data()}, b{keys_tmp.data(), idx_tmp.data()};
  if (threads == 1) {
    sort_range(a, b, n);
    return;
  }

  // Parallel top-level MSD pass a -> b: per-segment histograms give each thread its own
  // output offsets (bucket-major, then segment order: stable).
  std::vector<uint64_t> seg_varying(threads, 0);
  std::vector<std::array<size_t, kMsdBuckets>> hist(threads);
  std::array<size_t, kMsdBuckets + 1> bucket_begin{};
  int shift = 0;
  auto plan_shift = [&]() noexcept {
    uint64_t v = 0;
    for (auto s : seg_varying) v |= s;
    shift = msd_shift(v);
  };
  std::barrier sync_shift(std::ptrdiff_t(threads), plan_shift);
  auto plan_offsets = [&]() noexcept { histograms_to_offsets(hist, bucket_begin, kMsdBuckets); };
  std::barrier sync_offsets(std::ptrdiff_t(threads), plan_offsets);
  std::barrier sync_scatter{std::ptrdiff_t(threads)};
  std::atomic<size_t> next_bucket{0};

  auto worker = [&](unsigned t) {
    const size_t s = n * t / threads, e = n * (t + 1) / threads;
    // Varying bits need the global OR/AND; per segment OR and AND combined via the first key.
    uint64_t o = 0, an = ~uint64_t(0);
    for (size_t j = s; j < e; ++j) {
      o |= a.k[j];
      an &= a.k[j];
    }
    seg_varying[t] = (o ^ an) | (o ^ a.k[0]) | (an ^ a.k[0]);
    sync_shift.arrive_and_wait();
    auto& h = hist[t];
    h.fill(0);
    for (size_t j = s; j < e; ++j) ++h[(a.k[j] >> shift) & (kMsdBuckets - 1)];
    sync_offsets.arrive_and_wait();
    for (size_t j = s; j < e; ++j) {
      const size_t to = h[(a.k[j] >> shift) & (kMsdBuckets - 1)]++;
      b.k[to] = a.k[j];
      b.i[to] = a.i[j];
    }
    sync_scatter.arrive_and_wait();
    // Buckets: sort each in b (a as scratch), then copy it back to a.
    for (;;) {
      const size_t d = next_bucket.fetch_add(1);
      if (d >= kMsdBuckets) break;
      const size_t lo = bucket_begin[d], m = bucket_begin[d + 1] - lo;
      if (m == 0) continue;
      if (m > 1) sort_range(Span{b.k + lo, b.i + lo}, Span{a.k + lo, a.i + lo}, m);
      std::memcpy(a.k + lo, b.k + lo, m * sizeof(uint64_t));
      std::memcpy(a.i + lo, b.i + lo, m * sizeof(uint32_t));
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(worker, t);
  worker(0);
  for (auto& th : pool) th.join();
}

}  // namespace mds::convert
