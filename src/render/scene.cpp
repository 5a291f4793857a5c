#include "render/scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "culling/node_occupancy.h"
#include "store/type_style.h"

namespace mds::render {

glm::vec3 type_color_srgb(uint32_t type_index) {
  const store::Srgb c = store::default_type_color(type_index);
  return {c.r, c.g, c.b};
}

void set_type_colors(std::vector<gpu::GpuType>& types, std::span<const glm::vec3> colors_srgb) {
  for (size_t i = 0; i < types.size() && i < colors_srgb.size(); ++i) {
    const glm::vec3 c = colors_srgb[i];
    types[i].color = glm::vec4(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b), 1.0f);
  }
}

Result<std::vector<glm::vec3>> resolve_type_colors(std::span<const store::TypeEntry> types,
                                                   std::span<const store::TypeColorSpec> specs) {
  MDS_ASSIGN_OR_RETURN(const std::vector<store::Srgb> colors, store::type_colors(types, specs));
  std::vector<glm::vec3> out;
  out.reserve(colors.size());
  for (const store::Srgb& c : colors) out.emplace_back(c.r, c.g, c.b);
  return out;
}

float srgb_to_linear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }
float linear_to_srgb(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

float smallest_radius(const SceneData& s) {
  if (s.per_particle_radius) return s.radius_min;
  float r = 0.0f;
  bool first = true;
  for (size_t i = 0; i < s.types.size(); ++i) {
    if (i < s.shown_types.size() && !s.shown_types[i]) continue;
    r = first ? s.types[i].radius : std::min(r, s.types[i].radius);
    first = false;
  }
  return r;
}

SceneData begin_scene(const glm::dvec3& bounds_min, const glm::dvec3& bounds_max, std::span<const float> type_radius,
                      bool per_particle_radius, float radius_min, float radius_max) {
  SceneData s;
  s.origin = bounds_min;
  s.bounds.min = bounds_min;
  s.bounds.max = bounds_max;
  s.per_particle_radius = per_particle_radius;
  s.radius_min = radius_min;
  s.radius_max = radius_max;
  double rmax = per_particle_radius ? radius_max : 0.0;
  for (size_t i = 0; i < type_radius.size(); ++i) {
    gpu::GpuType t{};
    glm::vec3 c = type_color_srgb(uint32_t(i));
    t.color = glm::vec4(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b), 1.0f);
    t.radius = type_radius[i];
    s.types.push_back(t);
    if (!per_particle_radius) rmax = std::max(rmax, double(type_radius[i]));
  }
  s.bounds.radius_max = rmax;
  return s;
}

Status append_node(SceneData& s, const double center_min[3], const double center_max[3], const store::NodeData& node) {
  const size_t n = node.particle_count();
  if (n == 0) return make_error(Errc::format, "node {} is empty", s.nodes.size());
  if (s.particle_count() + n > std::numeric_limits<uint32_t>::max())
    return make_error(Errc::budget, "more than 2^32 particles: the in-memory renderer cannot index them");
  const uint32_t node_index = uint32_t(s.nodes.size());
  const uint32_t first_particle = uint32_t(s.particle_count());
  double step[3];
  for (int a = 0; a < 3; ++a) step[a] = (center_max[a] - center_min[a]) / double(store::kQuantMax);

  gpu::GpuNode g{};
  g.origin = glm::vec3(glm::dvec3(center_min[0], center_min[1], center_min[2]) - s.origin);
  g.step = glm::vec3(step[0], step[1], step[2]);
  g.first_particle = first_particle;
  g.particle_count = uint32_t(n);
  g.first_meshlet = uint32_t(s.meshlets.size());
  glm::vec3 node_min(std::numeric_limits<float>::max()), node_max(-std::numeric_limits<float>::max());
  float node_rmax = 0.0f;
  std::vector<glm::vec4> spheres;  // centre, radius: the node's occupancy once its box is known
  spheres.reserve(n);

  s.particles.reserve(s.particles.size() + 4 * n);
  for (size_t i = 0; i < n; ++i) {
    s.particles.push_back(node.qpos[3 * i + 0]);
    s.particles.push_back(node.qpos[3 * i + 1]);
    s.particles.push_back(node.qpos[3 * i + 2]);
    uint8_t t = node.type_index[i];
    if (t >= s.types.size())
      return make_error(Errc::format, "node {} particle {}: type index {} outside the type table ({} types)",
                        node_index, i, t, s.types.size());
    s.particles.push_back(t);
  }
  if (s.per_particle_radius) {
    if (node.radius_q.size() != n)
      return make_error(Errc::format, "node {}: per-particle radii missing", node_index);
    s.radius_q.insert(s.radius_q.end(), node.radius_q.begin(), node.radius_q.end());
  }
  if (s.has_property) {
    if (node.property_q.size() != n) return make_error(Errc::format, "node {}: per-particle property missing", node_index);
    s.property_q.insert(s.property_q.end(), node.property_q.begin(), node.property_q.end());
  }
  if (s.has_color) {
    if (node.color.size() != n) return make_error(Errc::format, "node {}: per-particle colours missing", node_index);
    s.color.insert(s.color.end(), node.color.begin(), node.color.end());
  }

  size_t p = 0;
  for (size_t k = 0; k < node.meshlet_size.size(); ++k) {
    const uint32_t count = node.meshlet_size[k];
    if (count == 0 || p + count > n)
      return make_error(Errc::format, "node {} meshlet {}: size {} overruns the node's {} particles", node_index, k,
                        count, n);
    gpu::GpuMeshlet m{};
    m.node = node_index;
    m.first_particle = first_particle + uint32_t(p);
    m.particle_count = count;
    m.split = count;  // one run (in memory every meshlet is contiguous)
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (size_t i = p; i < p + count; ++i) {
      glm::vec3 pos;
      for (int a = 0; a < 3; ++a) {
        double x = center_min[a] + double(node.qpos[3 * i + a]) * step[a];
        pos[a] = float(x - s.origin[a]);
      }
      float r = s.per_particle_radius
                    ? float(s.radius_min + double(node.radius_q[i]) * (s.radius_max - s.radius_min) / store::kQuantMax)
                    : s.types[node.type_index[i]].radius;
      lo = glm::min(lo, pos - r);
      hi = glm::max(hi, pos + r);
      node_rmax = std::max(node_rmax, r);
      spheres.push_back(glm::vec4(pos, r));
    }
    m.aabb_min = lo;
    m.aabb_max = hi;
    node_min = glm::min(node_min, lo);
    node_max = glm::max(node_max, hi);
    s.meshlets.push_back(m);
    s.max_meshlet_particles = std::max(s.max_meshlet_particles, count);
    p += count;
  }
  if (p != n)
    return make_error(Errc::format, "node {}: meshlet sizes sum to {}, node has {} particles", node_index, p, n);
  g.aabb_min = node_min;
  g.aabb_max = node_max;
  g.max_radius = node_rmax;
  culling::OccupancyBuilder occ({node_min.x, node_min.y, node_min.z}, {node_max.x, node_max.y, node_max.z});
  for (const glm::vec4& q : spheres) occ.add_sphere({q.x, q.y, q.z}, q.w);
  set_fine_occupancy(g, occ.fine());
  s.nodes.push_back(g);
  return {};
}

void set_fine_occupancy(gpu::GpuNode& g, std::span<const uint8_t, 64> fine) {
  set_occupancy(g, culling::coarse_occupancy(fine));
  for (int c = 0; c < 64; ++c) {
    uint32_t& word = g.occupancy_fine[c / 16][(c / 4) % 4];
    word = (word & ~(0xffu << (8 * (c % 4)))) | uint32_t(fine[c]) << (8 * (c % 4));
  }
}

void filter_particles(const store::NodeData& in, const ParticleFilter& f, store::NodeData& out) {
  out.qpos.clear();
  out.type_index.clear();
  out.radius_q.clear();
  out.property_q.clear();
  out.color.clear();
  out.meshlet_size.clear();
  const bool radius = !in.radius_q.empty(), property = !in.property_q.empty(), color = !in.color.empty();
  size_t total = 0;
  for (const uint8_t size : in.meshlet_size) total += size;
  if (total != in.particle_count() || in.qpos.size() != 3 * total || in.type_index.size() != total ||
      (radius && in.radius_q.size() != total) || (property && in.property_q.size() != total) ||
      (color && in.color.size() != total) ||
      (!f.slices.empty() && (!f.center_min || !f.center_max)) || (!f.property_kept.empty() && !property)) {
    out = in;  // malformed: left whole for append_node to report
    return;
  }
  double step[3] = {0, 0, 0};
  if (!f.slices.empty())
    for (int a = 0; a < 3; ++a) step[a] = (f.center_max[a] - f.center_min[a]) / double(store::kQuantMax);
  size_t p = 0;
  for (const uint8_t size : in.meshlet_size) {
    uint8_t kept = 0;
    for (size_t i = p; i < p + size; ++i) {
      const uint8_t t = in.type_index[i];
      if (t < f.shown.size() && !f.shown[t]) continue;
      if (!f.property_kept.empty() && !f.property_kept[in.property_q[i]]) continue;
      if (!f.slices.empty()) {
        std::array<double, 3> c;  // the centre as append_node decodes it
        for (int a = 0; a < 3; ++a) c[a] = f.center_min[a] + double(in.qpos[3 * i + a]) * step[a];
        if (!store::slices_keep(f.slices, c)) continue;
      }
      out.qpos.insert(out.qpos.end(), in.qpos.begin() + ptrdiff_t(3 * i), in.qpos.begin() + ptrdiff_t(3 * i + 3));
      out.type_index.push_back(t);
      if (radius) out.radius_q.push_back(in.radius_q[i]);
      if (property) out.property_q.push_back(in.property_q[i]);
      if (color) out.color.push_back(in.color[i]);
      ++kept;
    }
    if (kept > 0) out.meshlet_size.push_back(kept);
    p += size;
  }
}

void filter_types(const store::NodeData& in, std::span<const uint8_t> shown, store::NodeData& out) {
  filter_particles(in, ParticleFilter{shown, {}, nullptr, nullptr}, out);
}

Result<SceneData> load_scene(const store::StoreReader& reader, const SceneOptions& o) {
  const store::FileHeader& h = reader.header();
  const std::span<const uint8_t> shown = o.shown_types;
  std::vector<float> radii;
  for (const auto& t : reader.types()) radii.push_back(t.radius);
  const bool ppr = (h.flags & store::kFlagPerParticleRadius) != 0;
  if (!o.type_radius.empty()) {
    if (o.type_radius.size() != radii.size())
      return make_error(Errc::invalid_argument, "{}: {} type radii for {} types", reader.path().string(),
                        o.type_radius.size(), radii.size());
    if (ppr)
      return make_error(Errc::invalid_argument, "{}: the store has per-particle radii: type radii do not apply",
                        reader.path().string());
    radii = o.type_radius;
  }
  SceneData s = begin_scene({h.bounds_min[0], h.bounds_min[1], h.bounds_min[2]},
                            {h.bounds_max[0], h.bounds_max[1], h.bounds_max[2]}, radii, ppr, h.radius_min, h.radius_max);
  const bool hide = std::any_of(shown.begin(), shown.end(), [](uint8_t v) { return v == 0; });
  // Room for every particle, unless a filter keeps an unknown share (a threshold may keep a small
  // part of a store beyond the in-memory limit).
  const uint64_t reserve = hide || o.threshold ? 0 : h.particle_count;
  if (h.flags & store::kFlagProperty) {
    s.has_property = true;
    s.property_min = h.property_min;
    s.property_max = h.property_max;
    s.property_q.reserve(reserve);
  }
  if (h.flags & store::kFlagColor) {
    s.has_color = true;
    s.color.reserve(reserve);
  }
  s.particles.reserve(4 * reserve);
  if (reserve) s.meshlets.reserve(h.meshlet_count);
  store::NodeData node;
  std::vector<uint8_t> scratch;
  const auto nodes = reader.nodes();
  if (hide) s.shown_types.assign(shown.begin(), shown.end());
  s.slices = o.slices;
  s.threshold = o.threshold;
  std::vector<uint8_t> property_kept;
  if (o.threshold) {
    if (!s.has_property)
      return make_error(Errc::invalid_argument, "{}: --threshold {}: the store has no per-particle property (convert "
                        "--property NAME)", reader.path().string(), store::threshold_spec(*o.threshold));
    property_kept = store::threshold_table(*o.threshold, h.property_min, h.property_max);
  }
  const bool filter = s.left_out();
  store::NodeData kept;
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    const store::NodeEntry& e = nodes[i];
    store::SliceCover cover = store::SliceCover::all;
    if (!o.slices.empty()) {
      std::array<double, 3> lo, hi;
      store::decoded_box(e.center_min, e.center_max, lo, hi);
      cover = store::slices_cover(o.slices, lo, hi);
      if (cover == store::SliceCover::none) continue;  // not read
    }
    MDS_TRY(reader.read_node(i, node, scratch));
    if (hide || cover == store::SliceCover::some || o.threshold) {
      const ParticleFilter f{hide ? shown : std::span<const uint8_t>{},
                             cover == store::SliceCover::some ? std::span<const store::Slice>(o.slices)
                                                               : std::span<const store::Slice>{},
                             e.center_min, e.center_max, property_kept};
      filter_particles(node, f, kept);
      if (kept.particle_count() == 0) continue;
    } else {
      std::swap(kept, node);  // every particle: no copy
    }
    Status st = append_node(s, e.center_min, e.center_max, kept);
    if (!st.ok())
      return filter ? make_error(st.error().code, "{}: store node {} (particles left out): {}", reader.path().string(),
                                 i, st.error().message)
                    : make_error(st.error().code, "{}: {}", reader.path().string(), st.error().message);
  }
  if (s.particle_count() == 0 && o.threshold && o.slices.empty())
    return make_error(Errc::invalid_argument, "{}: --threshold {}{} leaves no particle of the store (its property '{}' "
                      "lies in [{:g}, {:g}])", reader.path().string(), store::threshold_spec(*o.threshold),
                      hide ? " with --hide-type" : "", h.property_name, h.property_min, h.property_max);
  if (s.particle_count() == 0 && !o.slices.empty()) {
    std::string specs;
    for (const store::Slice& sl : o.slices) specs += (specs.empty() ? "" : "; ") + store::slice_spec(sl);
    return make_error(Errc::invalid_argument, "{}: --slice leaves no particle of the store ({}){}", reader.path().string(),
                      specs, o.threshold ? " with --threshold " + store::threshold_spec(*o.threshold) : std::string());
  }
  return s;
}

Result<SceneOptions> resolve_scene_options(const store::StoreReader& reader, std::span<const std::string> hide_keys,
                                           std::span<const store::TypeRadiusSpec> radii,
                                           std::span<const store::Slice> slices, bool streaming,
                                           const std::optional<store::Threshold>& threshold) {
  SceneOptions o;
  o.slices.assign(slices.begin(), slices.end());  // streaming: the cache applies them (StreamSettings::slices)
  if (threshold) {  // streaming: the cache applies it too (StreamSettings::threshold)
    const store::FileHeader& h = reader.header();
    if (!(h.flags & store::kFlagProperty))
      return make_error(Errc::invalid_argument, "--threshold {}: {} has no per-particle property (convert --property NAME)",
                        store::threshold_spec(*threshold), reader.path().string());
    o.threshold = threshold;
  }
  if (hide_keys.empty() && radii.empty()) return o;
  const char* option = !hide_keys.empty() ? "--hide-type" : "--type-radius";
  if (streaming)
    return make_error(Errc::invalid_argument, "{} needs the whole store in memory (no --gpu-budget): the cache streams "
                      "whole nodes, and the store's density volume and node boxes describe every particle at its "
                      "radius", option);
  auto shown = store::shown_types(reader.types(), hide_keys);
  if (!shown) return make_error(Errc::invalid_argument, "--hide-type: {}", shown.error().message);
  o.shown_types = std::move(*shown);
  if (!radii.empty()) {
    if (reader.header().flags & store::kFlagPerParticleRadius)
      return make_error(Errc::invalid_argument, "--type-radius: {} has per-particle radii, which type radii do not change",
                        reader.path().string());
    auto r = store::type_radii(reader.types(), radii);
    if (!r) return make_error(Errc::invalid_argument, "--type-radius: {}", r.error().message);
    o.type_radius = std::move(*r);
  }
  return o;
}

Result<SceneData> scene_from_particles(std::span<const glm::dvec3> positions, std::span<const uint8_t> types,
                                       std::span<const float> type_radius, uint32_t node_size,
                                       uint32_t meshlet_size) {
  if (positions.empty() || positions.size() != types.size())
    return make_error(Errc::invalid_argument, "scene_from_particles: {} positions, {} types", positions.size(),
                      types.size());
  node_size = std::clamp<uint32_t>(node_size, 1, store::kMaxNodeParticles);
  meshlet_size = std::clamp<uint32_t>(meshlet_size, 1, store::kMaxMeshletParticles);
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const auto& p : positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  SceneData s = begin_scene(lo, hi, type_radius, false, 0.0f, 0.0f);
  store::NodeData node;
  for (size_t first = 0; first < positions.size(); first += node_size) {
    const size_t n = std::min<size_t>(node_size, positions.size() - first);
    double cmin[3], cmax[3];
    for (int a = 0; a < 3; ++a) {
      cmin[a] = std::numeric_limits<double>::max();
      cmax[a] = -std::numeric_limits<double>::max();
      for (size_t i = first; i < first + n; ++i) {
        cmin[a] = std::min(cmin[a], positions[i][a]);
        cmax[a] = std::max(cmax[a], positions[i][a]);
      }
    }
    node.qpos.resize(3 * n);
    node.type_index.assign(types.begin() + first, types.begin() + first + n);
    node.radius_q.clear();
    node.meshlet_size.clear();
    for (size_t i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) {
        double extent = cmax[a] - cmin[a];
        double q = extent > 0.0 ? std::round((positions[first + i][a] - cmin[a]) / extent * store::kQuantMax) : 0.0;
        node.qpos[3 * i + a] = uint16_t(std::clamp(q, 0.0, double(store::kQuantMax)));
      }
    }
    for (size_t done = 0; done < n; done += meshlet_size)
      node.meshlet_size.push_back(uint8_t(std::min<size_t>(meshlet_size, n - done)));
    MDS_TRY(append_node(s, cmin, cmax, node));
  }
  return s;
}

}  // namespace mds::render
