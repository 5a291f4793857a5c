// Picking the particle at a point of the image, on the CPU; see pick.h.
#include "render/pick.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "render/pixel_rays.h"
#include "store/slice.h"

namespace mds::render {
namespace {

// Where the ray (o, d) enters the box [lo, hi] (0 when it starts inside); negative when it
// misses the box or the box lies behind the origin.
double ray_box_entry(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi) {
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return -1.0;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return -1.0;
  }
  return t0;
}

}  // namespace

Result<std::optional<PickedParticle>> pick_particle(const store::StoreReader& reader, const Camera& camera,
                                                    uint32_t width, uint32_t height, glm::dvec2 pixel,
                                                    const SceneOptions& options) {
  if (width == 0 || height == 0 || !(pixel.x >= 0.0 && pixel.x <= double(width)) ||
      !(pixel.y >= 0.0 && pixel.y <= double(height)))
    return make_error(Errc::invalid_argument, "pick: the point ({}, {}) lies outside the {}x{} image", pixel.x,
                      pixel.y, width, height);
  if (!(camera.near > 0.0 && camera.far > camera.near))
    return make_error(Errc::invalid_argument, "pick: the camera needs fitted near/far planes");
  const PixelRays f(camera, width, height);
  glm::dvec3 o, d;
  f.ray(pixel.x, pixel.y, o, d);

  const store::FileHeader& h = reader.header();
  const auto nodes = reader.nodes();
  const auto types = reader.types();
  const bool ppr = (h.flags & store::kFlagPerParticleRadius) != 0;
  const bool has_property = (h.flags & store::kFlagProperty) != 0;
  std::vector<double> type_radius(types.size());
  double largest_override = 0.0;  // node boxes hold the store's radii; --type-radius may grow them
  // A node's max_radius is the converter's, before the radii were quantized: a decoded radius may
  // exceed it by half a quantization step.
  const double radius_slack = ppr ? 0.5 * (double(h.radius_max) - h.radius_min) / store::kQuantMax : 0.0;
  for (size_t t = 0; t < types.size(); ++t) {
    type_radius[t] = t < options.type_radius.size() ? double(options.type_radius[t]) : double(types[t].radius);
    if (t < options.type_radius.size()) largest_override = std::max(largest_override, type_radius[t]);
  }
  if (options.threshold && !has_property)
    return make_error(Errc::invalid_argument, "--threshold {}: {} has no per-particle property",
                      store::threshold_spec(*options.threshold), reader.path().string());
  const std::vector<uint8_t> property_kept =
      options.threshold ? store::threshold_table(*options.threshold, h.property_min, h.property_max)
                        : std::vector<uint8_t>{};
  const auto shown = [&](uint8_t t) { return options.shown_types.empty() || t >= options.shown_types.size() || options.shown_types[t]; };

  // The nodes the ray enters, nearest entry first.
  std::vector<std::pair<double, uint32_t>> order;
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    const store::NodeEntry& e = nodes[i];
    if (!options.slices.empty()) {
      std::array<double, 3> lo, hi;
      store::decoded_box(e.center_min, e.center_max, lo, hi);
      if (store::slices_cover(options.slices, lo, hi) == store::SliceCover::none) continue;
    }
    const double r = std::max(double(e.max_radius) + radius_slack, largest_override);
    glm::dvec3 vlo, vhi;
    view_box(f.view, glm::dvec3(e.center_min[0], e.center_min[1], e.center_min[2]) - r,
             glm::dvec3(e.center_max[0], e.center_max[1], e.center_max[2]) + r, vlo, vhi);
    const double t = ray_box_entry(o, d, vlo, vhi);
    if (t >= 0.0) order.emplace_back(t, i);
  }
  std::sort(order.begin(), order.end());

  std::optional<PickedParticle> best;
  double best_t = std::numeric_limits<double>::infinity();
  store::NodeData data;
  std::vector<uint8_t> scratch;
  for (const auto& [entry, i] : order) {
    if (entry > best_t) break;  // this box, and every later one, lies behind the hit
    const store::NodeEntry& e = nodes[i];
    MDS_TRY(reader.read_node(i, data, scratch));
    const double step[3] = {store::quant_step(e, 0), store::quant_step(e, 1), store::quant_step(e, 2)};
    size_t m = 0, meshlet_end = data.meshlet_size.empty() ? data.particle_count() : data.meshlet_size[0];
    for (size_t k = 0; k < data.particle_count(); ++k) {
      while (k >= meshlet_end && m + 1 < data.meshlet_size.size()) meshlet_end += data.meshlet_size[++m];
      const uint8_t type = data.type_index[k];
      if (!shown(type)) continue;
      if (!property_kept.empty() && !property_kept[data.property_q[k]]) continue;
      const std::array<double, 3> p = {e.center_min[0] + double(data.qpos[3 * k]) * step[0],
                                       e.center_min[1] + double(data.qpos[3 * k + 1]) * step[1],
                                       e.center_min[2] + double(data.qpos[3 * k + 2]) * step[2]};
      if (!options.slices.empty() && !store::slices_keep(options.slices, p)) continue;
      const double r = ppr ? h.radius_min + double(data.radius_q[k]) * (h.radius_max - h.radius_min) / store::kQuantMax
                           : (type < type_radius.size() ? type_radius[type] : 0.0);
      const glm::dvec3 c = glm::dvec3(f.view * glm::dvec4(p[0], p[1], p[2], 1.0));
      if (before_near_plane(c, r, f.near)) continue;
      const double t = ray_sphere_front(o, d, c, r);
      if (t < 0.0 || !(t < best_t)) continue;
      best_t = t;
      PickedParticle q;
      q.node = i;
      q.index_in_node = uint32_t(k);
      q.meshlet = e.first_meshlet + m;
      q.type = type;
      q.position = glm::dvec3(p[0], p[1], p[2]);
      q.radius = r;
      if (has_property && k < data.property_q.size())
        q.property = store::property_value(h.property_min, h.property_max, data.property_q[k]);
      if (k < data.color.size()) q.color = data.color[k];
      const glm::dvec3 hv = o + t * d;
      q.hit = glm::dvec3(glm::inverse(f.view) * glm::dvec4(hv, 1.0));
      q.distance = -hv.z;
      best = q;
    }
  }
  if (best) {
    uint64_t before = 0;
    for (uint32_t i = 0; i < best->node; ++i) before += nodes[i].particle_count;
    best->index = before + best->index_in_node;
  }
  return best;
}

Result<glm::uvec2> parse_pick_pixel(const std::string& text) {
  const size_t comma = text.find(',');
  const auto number = [](std::string s) -> std::optional<uint32_t> {
    const size_t b = s.find_first_not_of(' '), e = s.find_last_not_of(' ');
    s = b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
    if (s.empty() || s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
    return uint32_t(std::stoul(s));
  };
  std::optional<uint32_t> x, y;
  if (comma != std::string::npos) {
    x = number(text.substr(0, comma));
    y = number(text.substr(comma + 1));
  }
  if (!x || !y) return make_error(Errc::invalid_argument, "'{}': expected X,Y (a pixel: two integers >= 0)", text);
  return glm::uvec2(*x, *y);
}

std::string color_hex(uint32_t rgba) {
  return fmt::format("#{:02x}{:02x}{:02x}", rgba & 0xffu, (rgba >> 8) & 0xffu, (rgba >> 16) & 0xffu);
}

std::string describe_pick(const store::StoreReader& reader, const PickedParticle& p) {
  const auto types = reader.types();
  std::string type = "?";
  if (p.type < types.size()) {
    const store::TypeEntry& t = types[p.type];
    const std::string name(t.name, strnlen(t.name, sizeof(t.name)));
    type = name.empty() ? fmt::format("{}", t.input_id) : fmt::format("{} ({})", name, t.input_id);
  }
  std::string s = fmt::format("node {} particle {} (store index {}) type {} at ({:.6g}, {:.6g}, {:.6g}) r {:.4g}",
                              p.node, p.index_in_node, p.index, type, p.position.x, p.position.y, p.position.z,
                              p.radius);
  if (p.property) {
    const char* name = reader.header().property_name;
    s += fmt::format(", {} {:.6g}", std::string(name, strnlen(name, store::kPropertyNameBytes)), *p.property);
  }
  if (p.color) s += fmt::format(", colour {}", color_hex(*p.color));
  s += fmt::format(", distance {:.6g}", p.distance);
  return s;
}

}  // namespace mds::render
