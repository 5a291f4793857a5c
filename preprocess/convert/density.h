// The coarse particle density volume (paper 000, §3.1, §4.4 and §7.4): counts of particle
// centres on a regular grid over the global bounds (about 700k-1M voxels in the paper), and
// for every node the sorted list of voxels its particles fall in, with counts, so the
// renderer can subtract a node from the volume when it becomes occluded (§4.4 "Dynamic
// volume updates").
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"
#include "store/format.h"

namespace mds::convert {

inline constexpr uint64_t kDefaultDensityVoxels = 1u << 20;  // about 1M voxels
inline constexpr uint64_t kMaxDensityVoxels = 1ull << 28;

// --density-res: either a target voxel count ("1000000") or explicit dims ("64x64x32").
struct DensitySpec {
  uint64_t target_voxels = 0;  // 0 = default
  std::array<uint32_t, 3> dims = {0, 0, 0};
  bool explicit_dims = false;
};
Result<DensitySpec> parse_density_res(const std::string& text);

// Dims for about `target` voxels over the box [lo, hi], voxels as close to cubic as the
// extents allow; degenerate axes get 1 voxel; every dim >= 1; product <= max(1, target).
std::array<uint32_t, 3> choose_density_dims(const double lo[3], const double hi[3], uint64_t target);

// The default target: about 1M voxels, but at most about N/8 for small inputs.
uint64_t default_density_target(uint64_t particles);

class DensityGrid {
 public:
  DensityGrid() = default;
  DensityGrid(const double lo[3], const double hi[3], std::array<uint32_t, 3> dims);
  uint32_t voxel(double x, double y, double z) const {
    return cell(0, x) + dims_[0] * (cell(1, y) + dims_[1] * cell(2, z));
  }
  // Voxel coordinate along axis a (clamped to the grid).
  uint32_t cell(int a, double v) const {
    const double c = (v - lo_[a]) * scale_[a];
    if (!(c > 0)) return 0;
    const uint32_t i = uint32_t(c);
    return i >= dims_[a] ? dims_[a] - 1 : i;
  }
  uint64_t voxel_count() const { return uint64_t(dims_[0]) * dims_[1] * dims_[2]; }
  const std::array<uint32_t, 3>& dims() const { return dims_; }
  const double* lo() const { return lo_; }
  const double* hi() const { return hi_; }
  const double* scale() const { return scale_; }  // voxels per length unit, per axis

 private:
  std::array<uint32_t, 3> dims_ = {1, 1, 1};
  double lo_[3] = {0, 0, 0};
  double hi_[3] = {0, 0, 0};
  double scale_[3] = {0, 0, 0};
};

// Sorts `voxels` (one voxel index per particle; modified) and run-length encodes them.
void voxel_refs(std::vector<uint32_t>& voxels, std::vector<store::VoxelRef>& out);

// The same list from per-particle voxel coordinates (3 per particle, interleaved) inside the box
// [box_lo, box_hi] of voxel coordinates: counted in a dense array over the box when the box
// holds at most about 8 voxels per particle (nodes are compact, so almost always), else sorted.
// `scratch` is reused between calls.
void voxel_refs_in_box(std::span<const uint32_t> coords, const std::array<uint32_t, 3>& dims,
                       const uint32_t box_lo[3], const uint32_t box_hi[3], std::vector<uint32_t>& scratch,
                       std::vector<store::VoxelRef>& out);

}  // namespace mds::convert
