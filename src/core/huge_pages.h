// Transparent huge pages for large buffers (converter, readers, the store writer's blocks): one
// fault and one zeroing per 2 MiB instead of 512 faults of 4 KiB (docs/results/convert.md,
// "Huge pages").
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

namespace mds {

// The whole pages inside [p, p + bytes): [first, end) page-aligned addresses, empty (end <=
// first) when the range holds no whole page. madvise() takes only such ranges.
struct PageRange {
  uintptr_t first = 0, end = 0;
  bool empty() const { return end <= first; }
  size_t bytes() const { return empty() ? 0 : size_t(end - first); }
  void* data() const { return reinterpret_cast<void*>(first); }
};
inline PageRange whole_pages(const void* p, size_t bytes) {
  const uintptr_t page = uintptr_t(::sysconf(_SC_PAGESIZE));
  return {(uintptr_t(p) + page - 1) / page * page, (uintptr_t(p) + bytes) / page * page};
}

// Asks for huge pages on the whole pages inside [p, p + bytes) (madvise(MADV_HUGEPAGE)); the
// kernel uses them for the 2 MiB-aligned parts. Best effort: where THP is off ("never") or
// MDSTREAM_NO_HUGEPAGES is set (A/B runs), nothing changes and 4 KiB pages are used.
inline void advise_huge_pages(void* p, size_t bytes) {
#ifdef MADV_HUGEPAGE
  if (std::getenv("MDSTREAM_NO_HUGEPAGES")) return;
  const PageRange r = whole_pages(p, bytes);
  if (!r.empty()) (void)::madvise(r.data(), r.bytes(), MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

inline constexpr size_t kHugePageBytes = size_t(2) << 20;  // x86-64 transparent huge page

// A buffer of at least `bytes` bytes (rounded up to whole huge pages), 2 MiB-aligned, with huge
// pages asked for; release it with std::free. nullptr when the allocation fails.
inline void* allocate_huge_aligned(size_t bytes) {
  const size_t rounded = (std::max<size_t>(bytes, 1) + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
  void* p = std::aligned_alloc(kHugePageBytes, rounded);
  if (p) advise_huge_pages(p, rounded);
  return p;
}

}  // namespace mds
