// Allocation of the converter's large per-particle arrays (records, Morton keys, the sort
// permutation and its scratch): element construction is default-initialization, so resize()
// does not zero-fill arrays of hundreds of MiB that are overwritten right after. Plain
// std::vector semantics otherwise. Arrays of 4 MiB and more are mapped directly, and their pages
// can be mapped in bulk (prefault, BackgroundPrefault) rather than by one fault per page.
// Arrays of 4 MiB and more ask for transparent huge pages (madvise(MADV_HUGEPAGE)): one fault
// and one zeroing per 2 MiB instead of 512 faults (docs/results/convert.md, "Huge pages").
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <algorithm>
#include <new>
#include <thread>
#include <utility>
#include <vector>

#include "core/huge_pages.h"

namespace mds::convert {

template <class T>
struct BigAllocator {
  using value_type = T;
  BigAllocator() noexcept = default;
  template <class U>
  BigAllocator(const BigAllocator<U>&) noexcept {}

  // Large arrays come straight from mmap (page-aligned, returned to the system on free), so that
  // prefault() below can map their pages in bulk.
  T* allocate(size_t n) {
    const size_t bytes = n * sizeof(T);
    if (bytes < kMapThreshold) return static_cast<T*>(::operator new(bytes));
    void* p = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
    if (bytes >= kHugeThreshold) advise_huge_pages(p, bytes);
    return static_cast<T*>(p);
  }
  void deallocate(T* p, size_t n) noexcept {
    const size_t bytes = n * sizeof(T);
    if (bytes < kMapThreshold) ::operator delete(p);
    else ::munmap(p, bytes);
  }
  static constexpr size_t kMapThreshold = size_t(4) << 20;
  // 2 huge pages. 16 MiB before: the keys and permutations of a 1M-particle input (4-8 MiB
  // each) then took 4 KiB pages, and a 1M LAMMPS text conversion 1.27x the time (A/B in
  // docs/results/convert.md).
  static constexpr size_t kHugeThreshold = size_t(4) << 20;
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    if constexpr (sizeof...(Args) == 0) ::new (static_cast<void*>(p)) U;  // default-init: no zero fill
    else ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  template <class U>
  bool operator==(const BigAllocator<U>&) const noexcept { return true; }
};

template <class T>
using BigVector = std::vector<T, BigAllocator<T>>;

// Maps the whole pages inside [data, data + bytes) at once (madvise(MADV_POPULATE_WRITE)) instead
// of one page fault per 4 KiB page on first touch: on the 2-core VM about 40% less system time
// for the converter's arrays. Contents are never changed, so other threads may be writing the
// same range. Best effort: does nothing where unsupported.
inline void prefault(const void* data, size_t bytes) {
#ifdef MADV_POPULATE_WRITE
  const PageRange r = whole_pages(data, bytes);
  if (!r.empty()) (void)::madvise(r.data(), r.bytes(), MADV_POPULATE_WRITE);
#else
  (void)data;
  (void)bytes;
#endif
}

// Maps the pages of a freshly allocated array on a background thread
// (madvise(MADV_POPULATE_WRITE), 8 MiB at a time, front to back) while the calling thread fills
// it: the page faults of first touch (about 0.1 s of system time per 320 MB on the 2-core VM)
// leave the critical path. Contents are never changed. stop() (and the destructor) end it
// early; call it before the array is freed or reallocated.
class BackgroundPrefault {
 public:
  BackgroundPrefault() = default;
  BackgroundPrefault(void* data, size_t bytes) : BackgroundPrefault(std::vector<std::pair<void*, size_t>>{{data, bytes}}) {}
  // Several arrays, one after the other on the one thread.
  explicit BackgroundPrefault(std::vector<std::pair<void*, size_t>> regions) {
#ifdef MADV_POPULATE_WRITE
    std::vector<std::pair<uintptr_t, uintptr_t>> ranges;
    for (const auto& [data, bytes] : regions) {
      const PageRange r = whole_pages(data, bytes);
      if (!r.empty()) ranges.push_back({r.first, r.end});
    }
    if (ranges.empty()) return;
    thread_ = std::thread([this, ranges = std::move(ranges)] {
      constexpr uintptr_t kChunk = uintptr_t(8) << 20;
      for (const auto& [b, e] : ranges)
        for (uintptr_t at = b; at < e; at += kChunk) {
          if (stop_.load(std::memory_order_relaxed)) return;
          if (::madvise(reinterpret_cast<void*>(at), std::min(kChunk, e - at), MADV_POPULATE_WRITE) != 0) return;
        }
    });
#else
    (void)regions;
#endif
  }
  ~BackgroundPrefault() { stop(); }
  BackgroundPrefault(const BackgroundPrefault&) = delete;
  BackgroundPrefault& operator=(const BackgroundPrefault&) = delete;
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace mds::convert
