// GPU-ready scene arrays on the CPU: per-node quantization frames, per-meshlet records with
// bounds computed from the decoded positions, particles as uint16x4 (x, y, z, type) and the
// per-type colour/radius table. Everything position-like is float relative to `origin`
// (bounds_min of the store), which keeps float precision for large coordinates.
// Built from a store (load_scene) or from in-memory particles (scene_from_particles), both
// through append_node() -- the same decoded-node layout the store uses.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "core/result.h"
#include "gpu_types.h"
#include "render/camera.h"
#include "store/format.h"
#include "store/slice.h"
#include "store/store_reader.h"
#include "store/threshold.h"
#include "store/type_style.h"

namespace mds::render {

struct SceneData {
  glm::dvec3 origin{0.0};
  Bounds bounds;  // of particle centres, plus the largest radius
  bool per_particle_radius = false;
  float radius_min = 0.0f, radius_max = 0.0f;  // per-particle radius_q range
  uint32_t max_meshlet_particles = 0;
  std::vector<gpu::GpuNode> nodes;
  std::vector<gpu::GpuMeshlet> meshlets;
  std::vector<uint16_t> particles;  // 4 per particle: x, y, z, type
  std::vector<uint16_t> radius_q;   // 1 per particle, or empty
  // The store's per-particle property (store kFlagProperty; --color-by property): property_q 1
  // per particle, value = store::property_value(property_min, property_max, q).
  bool has_property = false;
  float property_min = 0.0f, property_max = 0.0f;
  std::vector<uint16_t> property_q;  // 1 per particle, or empty
  // The store's per-particle colours (store kFlagColor; --color-by color): RGBA8, R in bits 0..7.
  bool has_color = false;
  std::vector<uint32_t> color;  // 1 per particle, or empty
  std::vector<gpu::GpuType> types;
  std::vector<uint8_t> shown_types;  // per type, 0 = left out by load_scene; empty: every type
  std::vector<store::Slice> slices;  // what load_scene kept by position (--slice); empty: every position
  std::optional<store::Threshold> threshold;  // what load_scene kept by property (--threshold); none: all
  // load_scene left particles out (types, slices or a threshold): the store's density volume
  // counts particles the scene lacks (culling::density_on_grid), its node directory boxes
  // particles it lacks.
  bool left_out() const { return !shown_types.empty() || !slices.empty() || threshold.has_value(); }

  uint64_t particle_count() const { return particles.size() / 4; }
};

// Stores a sub-node occupancy mask (culling/node_occupancy.h) in the node record.
inline void set_occupancy(gpu::GpuNode& g, uint64_t mask) {
  g.occupancy_lo = uint32_t(mask);
  g.occupancy_hi = uint32_t(mask >> 32);
}
inline uint64_t occupancy(const gpu::GpuNode& g) { return uint64_t(g.occupancy_lo) | uint64_t(g.occupancy_hi) << 32; }
// Stores the fine level (and the coarse mask it implies).
void set_fine_occupancy(gpu::GpuNode& g, std::span<const uint8_t, 64> fine);  // culling::FineOccupancy

// The smallest particle radius of the scene (world units): radius_min with per-particle radii,
// else the smallest radius of the type table's shown types (0 for an empty table).
float smallest_radius(const SceneData& scene);

// Distinct per-type colour (store::default_type_color: Tableau 10, cycled), as sRGB in [0, 1].
glm::vec3 type_color_srgb(uint32_t type_index);
// Replaces the colour of types[i] by colors_srgb[i] (sRGB, stored linear) for the types both
// cover; the others keep theirs (RenderSettings::type_colors_srgb, empty: all keep).
void set_type_colors(std::vector<gpu::GpuType>& types, std::span<const glm::vec3> colors_srgb);
// Every type's colour (sRGB) for RenderSettings::type_colors_srgb: the palette, with the
// user's TYPE=COLOR specs resolved against the store's types (store::type_colors: its errors).
Result<std::vector<glm::vec3>> resolve_type_colors(std::span<const store::TypeEntry> types,
                                                   std::span<const store::TypeColorSpec> specs);
float srgb_to_linear(float c);
float linear_to_srgb(float c);

// Starts a scene: origin, bounds, type table (radius and colour per type).
SceneData begin_scene(const glm::dvec3& bounds_min, const glm::dvec3& bounds_max, std::span<const float> type_radius,
                      bool per_particle_radius, float radius_min, float radius_max);
// Appends one decoded node (store layout) with quantization frame center_min/max.
Status append_node(SceneData& scene, const double center_min[3], const double center_max[3],
                   const store::NodeData& node);

// What load_scene keeps of a store and how large it draws the particles (--hide-type,
// --type-radius; store/type_style.h; --slice, store/slice.h; --threshold, store/threshold.h).
struct SceneOptions {
  std::vector<uint8_t> shown_types;  // one per type index, 0 = left out; empty: every type
  std::vector<float> type_radius;    // one per type index, replacing the store's; empty: the store's
  std::vector<store::Slice> slices;  // particles kept by their centre (store::slices_keep); empty: all
  std::optional<store::Threshold> threshold;  // particles kept by their property value; none: all
};

// Decodes every node of the store (the store must fit in memory). With o.shown_types only the
// particles of shown types, with o.threshold only those whose decoded property value it keeps
// (Errc::invalid_argument for a store without a property), with o.slices only those whose
// decoded centre every slice keeps:
// meshlets keep their particles in order, a meshlet or node left empty is dropped, so scene nodes
// no longer match the store's node by node, and the store's density volume (which counts every
// particle) no longer describes the scene: cull with culling::density_on_grid (the store's grid,
// the scene's counts) when SceneData::left_out(). A node whose every centre the slices leave out
// is not read. The bounds (of the centres) and the type table's order stay the store's;
// SceneData::shown_types, slices and threshold record the options. Errc::invalid_argument when
// nothing is left.
// With o.type_radius the particles take those radii (without per-particle radii): the meshlet
// and node boxes and occupancy are computed from them, as they are from the store's.
Result<SceneData> load_scene(const store::StoreReader& reader, const SceneOptions& o = {});
// The SceneOptions of a user's --hide-type keys, --type-radius specs and --threshold against the
// store (store::shown_types, store::type_radii). Hidden types and type radii change what the
// renderer holds, so they need the store in memory: Errc::invalid_argument when `streaming` (the
// cache streams whole nodes, and the store's density volume and node boxes describe every
// particle at the store's radii), for --type-radius on a store with per-particle radii and for
// --threshold on a store without a property. Errors name the option. Slices (--slice) and the
// threshold are kept in both cases: load_scene applies them in memory, the streaming cache
// (StreamSettings::slices, ::threshold) when streaming.
Result<SceneOptions> resolve_scene_options(const store::StoreReader& reader, std::span<const std::string> hide_keys,
                                           std::span<const store::TypeRadiusSpec> radii,
                                           std::span<const store::Slice> slices, bool streaming,
                                           const std::optional<store::Threshold>& threshold = std::nullopt);

// Which particles of a decoded node filter_particles keeps.
struct ParticleFilter {
  std::span<const uint8_t> shown;       // per type index, 0 = left out (an index past it is kept)
  std::span<const store::Slice> slices;  // the decoded centre must be kept by each
  const double* center_min = nullptr;   // the node's quantization frame (3 each), needed with slices
  const double* center_max = nullptr;
  // Per quantized property value (store::threshold_table, kQuantMax + 1 entries), 0 = left out;
  // empty: every value. Needs the node's property_q.
  std::span<const uint8_t> property_kept;
};
// The particles of `in` that f keeps, meshlet by meshlet, into `out`; meshlets left empty are
// dropped. A centre is decoded as append_node decodes it.
void filter_particles(const store::NodeData& in, const ParticleFilter& f, store::NodeData& out);
// filter_particles by type alone.
void filter_types(const store::NodeData& in, std::span<const uint8_t> shown, store::NodeData& out);

// Quantizes in-memory particles into nodes of <= node_size particles (consecutive runs, in the
// given order) and meshlets of <= meshlet_size, exactly as a store would hold them.
Result<SceneData> scene_from_particles(std::span<const glm::dvec3> positions, std::span<const uint8_t> types,
                                       std::span<const float> type_radius, uint32_t node_size = 4096,
                                       uint32_t meshlet_size = 64);

}  // namespace mds::render
