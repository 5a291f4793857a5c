// Per-pass GPU timestamps: a query pool with begin/end pairs per named pass, read back after
// the frame's fence and accumulated per pass name (milliseconds).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

#include "core/result.h"
#include "vk/check.h"

namespace mds::vk {

class Context;

class TimestampPool {
 public:
  static Result<TimestampPool> create(Context& ctx, uint32_t max_passes = 16);
  TimestampPool() = default;
  TimestampPool(TimestampPool&&) = default;
  TimestampPool& operator=(TimestampPool&&) = default;

  bool enabled() const { return enabled_; }
  // Resets the pool for a new frame (recorded into cmd, before any begin()).
  void reset(VkCommandBuffer cmd);
  void begin(VkCommandBuffer cmd, const std::string& pass);
  void end(VkCommandBuffer cmd);
  // After the frame completed: appends each pass's duration (ms) to samples()[pass].
  Status collect();
  const std::map<std::string, std::vector<double>>& samples() const { return samples_; }

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  UniqueQueryPool pool_;
  bool enabled_ = false;
  double period_ns_ = 1.0;
  uint64_t valid_mask_ = ~0ull;
  uint32_t max_passes_ = 0;
  std::vector<std::string> frame_passes_;
  std::map<std::string, std::vector<double>> samples_;
};

double median(std::vector<double> v);

}  // namespace mds::vk
