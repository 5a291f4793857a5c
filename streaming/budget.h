// GPU memory budget for particle payloads (issue 4, "--gpu-budget BYTES").
// Follows Ibrahim et al. §8 (future work: data larger than GPU memory, a GPU-resident cache) and
// Grottel et al. §3.1/§3.3 (a fixed upload budget): every byte of particle payload on the device
// is reserved and released against ONE fixed-size pool here, and the peak is tracked so that
// `gpu_peak_bytes <= gpu_budget_bytes` can be asserted.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/byte_size.h"
#include "core/result.h"

namespace mds::streaming {

// Byte sizes (--gpu-budget) are parsed by mds::parse_byte_size (core/byte_size.h).
using mds::format_bytes;
using mds::parse_byte_size;

// The single accountant of device payload memory. Not thread-safe: owned by the render thread.
class DeviceBudget {
 public:
  explicit DeviceBudget(uint64_t pool_bytes) : pool_(pool_bytes) {}

  uint64_t pool_bytes() const { return pool_; }
  uint64_t used_bytes() const { return used_; }
  uint64_t free_bytes() const { return pool_ - used_; }
  uint64_t peak_bytes() const { return peak_; }
  uint64_t reservations() const { return count_; }

  bool fits(uint64_t bytes) const { return bytes <= free_bytes(); }
  // A request larger than the whole pool can never fit (Errc::budget, names both sizes).
  Status check_fits_pool(uint64_t bytes, std::string_view what) const;
  // Reserves `bytes`; Errc::budget if larger than the pool, or than what is free now
  // (the caller must evict first).
  Status reserve(uint64_t bytes, std::string_view what = "payload");
  // Releases a previous reservation; Errc::internal if more than is reserved.
  Status release(uint64_t bytes);

 private:
  uint64_t pool_ = 0;
  uint64_t used_ = 0;
  uint64_t peak_ = 0;
  uint64_t count_ = 0;
};

}  // namespace mds::streaming
