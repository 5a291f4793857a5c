// Transparent huge pages for large buffers (converter, readers, the store writer's blocks): one
// fault and one zeroing per 2 MiB instead of 512 faults of 4 KiB (docs/results/convert.md,
// "Huge pages").
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>

namespace mds {

// Asks for huge pages on the whole pages inside [p, p + bytes) (madvise(MADV_HUGEPAGE)); the
// kernel uses them for the 2 MiB-aligned parts. Best effort: where THP is off ("never") or
// MDSTREAM_NO_HUGEPAGES is set (A/B runs), nothing changes and 4 KiB pages are used.
inline void advise_huge_pages(void* p, size_t bytes) {
#ifdef MADV_HUGEPAGE
  if (std::getenv("MDSTREAM_NO_HUGEPAGES")) return;
  const uintptr_t page = uintptr_t(::sysconf(_SC_PAGESIZE));
  const uintptr_t b = (uintptr_t(p) + page - 1) / page * page, e = (uintptr_t(p) + bytes) / page * page;
  if (e > b) (void)::madvise(reinterpret_cast<void*>(b), e - b, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

}  // namespace mds
