// Parallel radix sort of (Morton key, index) pairs: the converter sorts each in-memory bin by
// key (paper 000, §6: particles ordered along the Z-order curve before nodes and meshlets).
// One parallel MSD pass on the highest 11 varying key bits scatters the pairs into up to 2048
// buckets (each thread histograms and scatters its own contiguous segment, so the pass is
// stable); the buckets, mostly cache-sized, are then sorted independently by the threads:
// LSD passes (11-bit digits, stable) when at most two digits still vary, else another MSD
// pass whose digit width follows the bucket size (~log2 n bits, so sub-buckets hold a few
// pairs each and end in insertion sort). Uniform 63-bit keys thus take 2 scatter passes.
// Bits equal in every key of a range (for example the shared Morton prefix of an
// out-of-core bin) are skipped. O(n) per pass.
#pragma once

#include <cstdint>
#include <span>
#include <type_traits>

namespace mds::convert {

// Per-thread digit histograms (hist[t][d]) -> per-thread scatter offsets, in place, and bucket
// starts (bucket_begin[0..buckets]): bucket d of thread t starts after every key of a smaller
// digit and after the keys of digit d of threads < t (a stable parallel scatter).
template <class Hist, class Begin>
void histograms_to_offsets(Hist& hist, Begin& bucket_begin, size_t buckets) {
  using T = std::remove_cvref_t<decltype(bucket_begin[0])>;
  T at = 0;
  for (size_t d = 0; d < buckets; ++d) {
    bucket_begin[d] = at;
    for (auto& h : hist) {
      const T c = T(h[d]);
      h[d] = static_cast<std::remove_cvref_t<decltype(h[d])>>(at);
      at += c;
    }
  }
  bucket_begin[buckets] = at;
}

// Sorts `keys` ascending and permutes `idx` alongside (stable); the result is in keys/idx.
// `keys_tmp`/`idx_tmp` are scratch of the same size. All four spans have the same length.
void radix_sort_pairs(std::span<uint64_t> keys, std::span<uint32_t> idx, std::span<uint64_t> keys_tmp,
                      std::span<uint32_t> idx_tmp, unsigned threads);

// The same on one thread over raw arrays of n pairs (scratch kt/it of n each).
void radix_sort_pairs_serial(uint64_t* keys, uint32_t* idx, uint64_t* keys_tmp, uint32_t* idx_tmp, size_t n);

}  // namespace mds::convert
