// The particle density volume of the culling loop (paper 000, Sect. 3.1 / 4.4) on the CPU side:
// a regular grid of particle counts (density = count / cell volume), taken from the store or
// binned from the scene, and the static per-meshlet voxel contributions that the dynamic volume
// update subtracts when a meshlet reaches class O ("we pre-compute a (static) list of voxels
// affected by any meshlet becoming occluded", Sect. 4.4).
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/result.h"
#include "render/scene.h"
#include "store/store_reader.h"

namespace mds::render::culling {

struct DensityVolume {
  glm::ivec3 dims{0};
  glm::dvec3 origin{0.0};  // box min, relative to the scene origin (SceneData::origin)
  glm::dvec3 cell{1.0};
  std::vector<int32_t> counts;  // x fastest
  uint64_t total() const;
};

// The store's density volume (header density_dims / density_min / density_max and counts).
Result<DensityVolume> density_from_store(const store::StoreReader& reader, const SceneData& scene);
Result<DensityVolume> density_from_store(const store::StoreReader& reader, const glm::dvec3& origin);
// Bins the scene's decoded particle centres into a grid over the centre bounds whose longest
// axis has `max_dim` cells (cubic cells).
DensityVolume density_from_scene(const SceneData& scene, int max_dim = 64);
// The scene's decoded particle centres binned into `grid`'s cells (its counts replaced): the
// store's grid for a scene that holds only some of the store's particles (load_scene's shown
// types), whose own counts would include the particles left out.
DensityVolume density_on_grid(const SceneData& scene, DensityVolume grid);

// Per-meshlet voxel contributions (CSR): meshlet m holds refs[first[m] .. first[m+1]) as
// (voxel index, particle count), from the decoded particle positions (the positions the GPU
// draws). Particles outside the volume box are clamped to the border cell, as the converter does.
struct MeshletVoxels {
  std::vector<uint32_t> first;   // meshlets + 1
  std::vector<glm::uvec2> refs;
};
MeshletVoxels meshlet_voxels(const SceneData& scene, const DensityVolume& volume);

// Decoded centre of particle i (float, relative to the scene origin), exactly as the shaders do.
glm::vec3 decoded_position(const SceneData& scene, uint32_t node, uint64_t particle);

}  // namespace mds::render::culling
