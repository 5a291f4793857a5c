// Allocation of the converter's large per-particle arrays (records, Morton keys, the sort
// permutation and its scratch): element construction is default-initialization, so resize()
// does not zero-fill arrays of hundreds of MiB that are overwritten right after. Plain
// std::vector semantics otherwise. (Transparent huge pages via madvise were tried: no gain on
// the 2-core VM, and occasional stalls of direct compaction, so not used.)
#pragma once

#include <cstddef>
#include <new>
#include <utility>
#include <vector>

namespace mds::convert {

template <class T>
struct BigAllocator {
  using value_type = T;
  BigAllocator() noexcept = default;
  template <class U>
  BigAllocator(const BigAllocator<U>&) noexcept {}

  T* allocate(size_t n) { return static_cast<T*>(::operator new(n * sizeof(T))); }
  void deallocate(T* p, size_t) noexcept { ::operator delete(p); }
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

}  // namespace mds::convert
