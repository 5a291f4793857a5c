// Density volume dims and per-node voxel lists (see density.h; paper 000 §4.4, §7.4).
#include "convert/density.h"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace mds::convert {

namespace {

bool parse_u64(std::string_view s, uint64_t& v) {
  if (s.empty()) return false;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && p == s.data() + s.size();
}

}  // namespace

Result<DensitySpec> parse_density_res(const std::string& text) {
  DensitySpec spec;
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const auto x1 = t.find('x');
  if (x1 == std::string::npos) {
    uint64_t v = 0;
    if (!parse_u64(t, v) || v == 0)
      return make_error(Errc::invalid_argument, "--density-res '{}': expected a voxel count N > 0 or dims AxBxC", text);
    if (v > kMaxDensityVoxels)
      return make_error(Errc::invalid_argument, "--density-res {}: more than {} voxels", v, kMaxDensityVoxels);
    spec.target_voxels = v;
    return spec;
  }
  const auto x2 = t.find('x', x1 + 1);
  if (x2 == std::string::npos || t.find('x', x2 + 1) != std::string::npos)
    return make_error(Errc::invalid_argument, "--density-res '{}': expected dims AxBxC", text);
  uint64_t d[3];
  if (!parse_u64(std::string_view(t).substr(0, x1), d[0]) ||
      !parse_u64(std::string_view(t).substr(x1 + 1, x2 - x1 - 1), d[1]) ||
      !parse_u64(std::string_view(t).substr(x2 + 1), d[2]) || d[0] == 0 || d[1] == 0 || d[2] == 0)
    return make_error(Errc::invalid_argument, "--density-res '{}': dims must be positive integers AxBxC", text);
  if (d[0] > kMaxDensityVoxels || d[1] > kMaxDensityVoxels || d[2] > kMaxDensityVoxels ||
      d[0] * d[1] * d[2] > kMaxDensityVoxels)
    return make_error(Errc::invalid_argument, "--density-res {}: more than {} voxels", text, kMaxDensityVoxels);
  spec.explicit_dims = true;
  spec.dims = {uint32_t(d[0]), uint32_t(d[1]), uint32_t(d[2])};
  return spec;
}

uint64_t default_density_target(uint64_t particles) {
  return std::clamp<uint64_t>(particles / 8, 1, kDefaultDensityVoxels);
}

std::array<uint32_t, 3> choose_density_dims(const double lo[3], const double hi[3], uint64_t target) {
  std::array<uint32_t, 3> dims = {1, 1, 1};
  if (target <= 1) return dims;
  double ext[3];
  double maxext = 0;
  for (int a = 0; a < 3; ++a) {
    ext[a] = std::max(0.0, hi[a] - lo[a]);
    maxext = std::max(maxext, ext[a]);
  }
  if (!(maxext > 0)) return dims;
  bool live[3];
  for (int a = 0; a < 3; ++a) live[a] = ext[a] > maxext * 1e-9;  // flat axes get one voxel
  // Cubic voxels of side s with prod over live axes of ext/s == target; an axis thinner
  // than s gets one voxel and leaves the live set, then s is recomputed.
  double s = maxext;
  for (int iter = 0; iter < 3; ++iter) {
    double volume = 1;
    int k = 0;
    for (int a = 0; a < 3; ++a)
      if (live[a]) {
        volume *= ext[a];
        ++k;
      }
    s = std::pow(volume / double(target), 1.0 / k);
    bool changed = false;
    for (int a = 0; a < 3; ++a)
      if (live[a] && ext[a] < s && k > 1) {
        live[a] = false;
        changed = true;
      }
    if (!changed) break;
  }
  for (int a = 0; a < 3; ++a)
    dims[a] = live[a] ? uint32_t(std::clamp(std::floor(ext[a] / s), 1.0, double(kMaxDensityVoxels))) : 1;
  return dims;
}

DensityGrid::DensityGrid(const double lo[3], const double hi[3], std::array<uint32_t, 3> dims) : dims_(dims) {
  for (int a = 0; a < 3; ++a) {
    dims_[a] = std::max<uint32_t>(1, dims_[a]);
    lo_[a] = lo[a];
    hi_[a] = hi[a];
    const double e = hi[a] - lo[a];
    scale_[a] = e > 0 ? double(dims_[a]) / e : 0.0;
  }
}

void voxel_refs(std::vector<uint32_t>& voxels, std::vector<store::VoxelRef>& out) {
  out.clear();
  std::sort(voxels.begin(), voxels.end());
  for (size_t i = 0; i < voxels.size();) {
    size_t j = i + 1;
    while (j < voxels.size() && voxels[j] == voxels[i]) ++j;
    out.push_back({voxels[i], uint32_t(j - i)});
    i = j;
  }
}

void voxel_refs_in_box(std::span<const uint32_t> coords, const std::array<uint32_t, 3>& dims,
                       const uint32_t box_lo[3], const uint32_t box_hi[3], std::vector<uint32_t>& scratch,
                       std::vector<store::VoxelRef>& out) {
  out.clear();
  const size_t n = coords.size() / 3;
  const uint64_t wx = uint64_t(box_hi[0]) - box_lo[0] + 1, wy = uint64_t(box_hi[1]) - box_lo[1] + 1,
                 wz = uint64_t(box_hi[2]) - box_lo[2] + 1;
  const uint64_t volume = wx * wy * wz;
  if (volume > 8 * uint64_t(n) + 4096) {
    scratch.resize(n);
    for (size_t i = 0; i < n; ++i)
      scratch[i] = coords[3 * i] + dims[0] * (coords[3 * i + 1] + dims[1] * coords[3 * i + 2]);
    voxel_refs(scratch, out);
    return;
  }
  scratch.assign(size_t(volume), 0);
  for (size_t i = 0; i < n; ++i)
    ++scratch[size_t((coords[3 * i] - box_lo[0]) +
                     wx * ((coords[3 * i + 1] - box_lo[1]) + wy * uint64_t(coords[3 * i + 2] - box_lo[2])))];
  // z-major, then y, then x: increasing global index x + dims.x * (y + dims.y * z).
  size_t at = 0;
  for (uint64_t z = 0; z < wz; ++z)
    for (uint64_t y = 0; y < wy; ++y) {
      const uint32_t row = uint32_t(box_lo[0] + dims[0] * ((box_lo[1] + y) + dims[1] * (box_lo[2] + z)));
      for (uint64_t x = 0; x < wx; ++x, ++at)
        if (scratch[at]) out.push_back({row + uint32_t(x), scratch[at]});
    }
}

}  // namespace mds::convert
