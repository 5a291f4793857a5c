// Particle density volume and per-meshlet voxel contributions (paper 000, Sect. 3.1 / 4.4).
#include "render/culling/density_volume.h"

#include <algorithm>
#include <cmath>

namespace mds::render::culling {

uint64_t DensityVolume::total() const {
  uint64_t s = 0;
  for (int32_t c : counts) s += uint64_t(std::max(c, 0));
  return s;
}

glm::vec3 decoded_position(const SceneData& scene, uint32_t node, uint64_t particle) {
  const gpu::GpuNode& n = scene.nodes[node];
  const uint16_t* q = &scene.particles[4 * particle];
  return n.origin + glm::vec3(float(q[0]), float(q[1]), float(q[2])) * n.step;
}

Result<DensityVolume> density_from_store(const store::StoreReader& reader, const SceneData& scene) {
  return density_from_store(reader, scene.origin);
}

Result<DensityVolume> density_from_store(const store::StoreReader& reader, const glm::dvec3& origin) {
  const store::FileHeader& h = reader.header();
  DensityVolume v;
  v.dims = glm::ivec3(int(h.density_dims[0]), int(h.density_dims[1]), int(h.density_dims[2]));
  if (v.dims.x <= 0 || v.dims.y <= 0 || v.dims.z <= 0)
    return make_error(Errc::format, "{}: density volume has dims {}x{}x{}", reader.path().string(), v.dims.x,
                      v.dims.y, v.dims.z);
  for (int a = 0; a < 3; ++a) {
    v.origin[a] = h.density_min[a] - origin[a];
    v.cell[a] = std::max((h.density_max[a] - h.density_min[a]) / v.dims[a], 1e-30);
  }
  auto c = reader.density_counts();
  v.counts.resize(c.size());
  for (size_t i = 0; i < c.size(); ++i) v.counts[i] = int32_t(std::min<uint32_t>(c[i], INT32_MAX));
  return v;
}

namespace {
uint32_t voxel_of(const DensityVolume& v, const glm::vec3& p) {
  int c[3];
  for (int a = 0; a < 3; ++a)
    c[a] = std::clamp(int(std::floor((double(p[a]) - v.origin[a]) / v.cell[a])), 0, v.dims[a] - 1);
  return uint32_t(c[0] + v.dims.x * (c[1] + v.dims.y * c[2]));
}
}  // namespace

DensityVolume density_from_scene(const SceneData& scene, int max_dim) {
  DensityVolume v;
  glm::dvec3 lo = scene.bounds.min - scene.origin, hi = scene.bounds.max - scene.origin;
  glm::dvec3 ext = glm::max(hi - lo, glm::dvec3(1e-6));
  double cell = std::max({ext.x, ext.y, ext.z}) / std::max(max_dim, 1);
  for (int a = 0; a < 3; ++a) v.dims[a] = std::max(1, int(std::ceil(ext[a] / cell)));
  v.cell = glm::dvec3(cell);
  v.origin = lo;
  v.counts.assign(size_t(v.dims.x) * v.dims.y * v.dims.z, 0);
  for (const auto& m : scene.meshlets)
    for (uint32_t i = 0; i < m.particle_count; ++i)
      v.counts[voxel_of(v, decoded_position(scene, m.node, uint64_t(m.first_particle) + i))]++;
  return v;
}

DensityVolume density_on_grid(const SceneData& scene, DensityVolume grid) {
  grid.counts.assign(size_t(grid.dims.x) * grid.dims.y * grid.dims.z, 0);
  for (const auto& m : scene.meshlets)
    for (uint32_t i = 0; i < m.particle_count; ++i)
      grid.counts[voxel_of(grid, decoded_position(scene, m.node, uint64_t(m.first_particle) + i))]++;
  return grid;
}

MeshletVoxels meshlet_voxels(const SceneData& scene, const DensityVolume& volume) {
  MeshletVoxels mv;
  mv.first.reserve(scene.meshlets.size() + 1);
  std::vector<uint32_t> vox;
  for (const auto& m : scene.meshlets) {
    mv.first.push_back(uint32_t(mv.refs.size()));
    vox.clear();
    for (uint32_t i = 0; i < m.particle_count; ++i)
      vox.push_back(voxel_of(volume, decoded_position(scene, m.node, uint64_t(m.first_particle) + i)));
    std::sort(vox.begin(), vox.end());
    for (size_t i = 0; i < vox.size();) {
      size_t j = i;
      while (j < vox.size() && vox[j] == vox[i]) ++j;
      mv.refs.push_back(glm::uvec2(vox[i], uint32_t(j - i)));
      i = j;
    }
  }
  mv.first.push_back(uint32_t(mv.refs.size()));
  if (mv.refs.empty()) mv.refs.push_back(glm::uvec2(0));  // never read; keeps the buffer non-empty
  return mv;
}

}  // namespace mds::render::culling
