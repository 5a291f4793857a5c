// See budget.h (Ibrahim et al. §8; Grottel et al. §3.1 upload budget).
#include "streaming/budget.h"

#include <string>

namespace mds::streaming {

Status DeviceBudget::check_fits_pool(uint64_t bytes, std::string_view what) const {
  if (bytes > pool_)
    return make_error(Errc::budget, "GPU budget {} ({} bytes) cannot hold {} of {} bytes", format_bytes(pool_), pool_, what, bytes);
  return {};
}

Status DeviceBudget::reserve(uint64_t bytes, std::string_view what) {
  MDS_TRY(check_fits_pool(bytes, what));
  if (bytes > free_bytes())
    return make_error(Errc::budget, "GPU budget {}: {} of {} bytes does not fit, {} of {} bytes in use (evict first)", format_bytes(pool_), what,
                      bytes, used_, pool_);
  used_ += bytes;
  peak_ = std::max(peak_, used_);
  ++count_;
  return {};
}

Status DeviceBudget::release(uint64_t bytes) {
  if (bytes > used_) return make_error(Errc::internal, "GPU budget: releasing {} bytes but only {} are reserved", bytes, used_);
  used_ -= bytes;
  return {};
}

}  // namespace mds::streaming
