#include "vk/timestamps.h"

#include <algorithm>

#include "vk/context.h"

namespace mds::vk {

Result<TimestampPool> TimestampPool::create(Context& ctx, uint32_t max_passes) {
  TimestampPool t;
  t.device_ = ctx.device();
  t.max_passes_ = max_passes;
  t.enabled_ = ctx.timestamps() && ctx.limits().timestampComputeAndGraphics;
  if (!t.enabled_) return t;
  t.period_ns_ = ctx.timestamp_period_ns();
  VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = 2 * max_passes;
  VkQueryPool pool = VK_NULL_HANDLE;
  MDS_VK_TRY(vkCreateQueryPool(t.device_, &info, nullptr, &pool));
  t.pool_ = UniqueQueryPool(t.device_, pool);
  return t;
}

void TimestampPool::reset(VkCommandBuffer cmd) {
  frame_passes_.clear();
  if (enabled_) vkCmdResetQueryPool(cmd, pool_, 0, 2 * max_passes_);
}

void TimestampPool::begin(VkCommandBuffer cmd, const std::string& pass) {
  if (!enabled_ || frame_passes_.size() >= max_passes_) return;
  vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, pool_, uint32_t(2 * frame_passes_.size()));
  frame_passes_.push_back(pass);
}

void TimestampPool::end(VkCommandBuffer cmd) {
  if (!enabled_ || frame_passes_.empty()) return;
  vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, pool_, uint32_t(2 * frame_passes_.size() - 1));
}

Status TimestampPool::collect() {
  if (!enabled_ || frame_passes_.empty()) return {};
  std::vector<uint64_t> ticks(2 * frame_passes_.size());
  MDS_VK_TRY(vkGetQueryPoolResults(device_, pool_, 0, uint32_t(ticks.size()), ticks.size() * sizeof(uint64_t),
                                   ticks.data(), sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  for (size_t i = 0; i < frame_passes_.size(); ++i) {
    double ns = double(ticks[2 * i + 1] - ticks[2 * i]) * period_ns_;
    samples_[frame_passes_[i]].push_back(ns * 1e-6);
  }
  frame_passes_.clear();
  return {};
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace mds::vk
