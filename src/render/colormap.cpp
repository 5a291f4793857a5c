// Colour by coordinate: the colormaps and the view-space plane of the colormap coordinate
// (render/colormap.h; mirrored by shaders/include/particle_color.h).
#include "render/colormap.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <iterator>

#include "gpu_types.h"
#include "render/colormap_table.h"

namespace mds::render {

namespace {
constexpr const char* kColormapNames[] = {"viridis", "plasma", "magma", "inferno", "cividis", "turbo", "coolwarm", "gray"};
static_assert(std::size(kColormapNames) == kColormapTableCount, "render::Colormap and colormap_table.h disagree");
static_assert(kColormapTableSamples == gpu::kColormapSamples, "FrameUniforms::colormap holds a map's samples");
}  // namespace

const char* colormap_name(Colormap m) {
  const size_t i = size_t(m);
  return i < std::size(kColormapNames) ? kColormapNames[i] : "viridis";
}

Result<Colormap> parse_colormap(std::string_view s) {
  for (size_t i = 0; i < std::size(kColormapNames); ++i)
    if (s == kColormapNames[i]) return Colormap(i);
  return make_error(Errc::invalid_argument,
                    "'{}': expected viridis, plasma, magma, inferno, cividis, turbo, coolwarm or gray", s);
}

glm::dvec3 colormap_sample(Colormap m, unsigned k) {
  const size_t i = std::min<size_t>(size_t(m), kColormapTableCount - 1) * kColormapTableSamples +
                   std::min(k, kColormapTableSamples - 1);
  return {kColormapTable[i][0], kColormapTable[i][1], kColormapTable[i][2]};
}

glm::dvec3 colormap_srgb(Colormap m, double t) {
  // mds_colormap_srgb (shaders/include/particle_color.h) in double: the same index and weight.
  if (!(t >= 0.0)) t = 0.0;  // NaN: the first sample (and no NaN converted to unsigned below)
  const double x = std::clamp(t, 0.0, 1.0) * double(kColormapTableSamples - 1);
  const unsigned i = std::min(unsigned(x), kColormapTableSamples - 2);
  const double f = x - double(i);
  return colormap_sample(m, i) * (1.0 - f) + colormap_sample(m, i + 1) * f;  // GLSL mix
}

Result<int> parse_color_axis(std::string_view s) {
  if (s == "type") return -1;
  if (s == "x") return 0;
  if (s == "y") return 1;
  if (s == "z") return 2;
  if (s == "property") return kColorByProperty;
  if (s == "color") return kColorByColor;
  if (s == "auto") return kColorByAuto;
  return make_error(Errc::invalid_argument, "'{}': expected type, color, auto, x, y, z or property", s);
}

Result<glm::dvec2> parse_color_range(std::string_view s) {
  const size_t colon = s.find(':');
  auto number = [](std::string_view t, double& v) {
    const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
    return ec == std::errc() && end == t.data() + t.size() && std::isfinite(v);
  };
  double lo = 0.0, hi = 0.0;
  if (colon == std::string_view::npos || !number(s.substr(0, colon), lo) || !number(s.substr(colon + 1), hi))
    return make_error(Errc::invalid_argument, "'{}': expected LO:HI, two numbers", s);
  if (!(lo < hi)) return make_error(Errc::invalid_argument, "'{}': LO must be below HI", s);
  return glm::dvec2(lo, hi);
}

std::string color_axis_name(int axis) {
  static const char* names[8] = {"type", "x", "y", "z", "property", "property", "color", "auto"};
  return names[std::clamp(axis + 1, 0, 7)];
}

glm::dvec4 color_plane(const glm::dmat4& view, const glm::dvec3& origin, int axis, double lo, double hi) {
  // p_world = origin + inverse(view) * p_view; t = (p_world[axis] - lo) / (hi - lo). Row `axis`
  // of the inverse (glm: m[column][row]) gives p_world[axis] - origin[axis] as an affine form.
  const glm::dmat4 inv = glm::inverse(view);
  const double s = 1.0 / (hi - lo);
  return {inv[0][axis] * s, inv[1][axis] * s, inv[2][axis] * s, (inv[3][axis] + origin[axis] - lo) * s};
}

Status resolve_color_by(ColorBy& c, const char* property_name, bool has_property, bool has_color,
                        const std::string& store_name) {
  if (c.axis == kColorByColor || c.axis == kColorByAuto) {
    if (c.axis == kColorByColor && !has_color)
      return make_error(Errc::invalid_argument,
                        "--color-by color: {} has no per-particle colours (convert MMPLD or extended XYZ input with "
                        "--color)",
                        store_name);
    c.axis = -1;
    c.particle_colors = has_color;
    return {};
  }
  if (c.axis != kColorByName) return {};
  if (has_property && c.name == property_name) {
    c.axis = kColorByProperty;
    return {};
  }
  return make_error(Errc::invalid_argument, "--color-by '{}': expected auto, type, color, x, y, z, property or {}", c.name,
                    has_property ? fmt::format("the name of {}'s property, {}", store_name, property_name)
                                 : fmt::format("a property's name, but {} has no property (convert --property NAME)",
                                               store_name));
}

glm::dvec2 property_color_map(double pmin, double pmax, double lo, double hi) {
  const double s = 1.0 / (hi - lo);
  return {(pmax - pmin) / 65535.0 * s, (pmin - lo) * s};  // 65535 = store::kQuantMax
}

glm::dvec2 property_default_range(double pmin, double pmax) {
  if (pmin < pmax) return {pmin, pmax};
  const double pad = std::max(1e-6 * std::abs(pmin), 1e-12);
  return {pmin - pad, pmin + pad};
}

}  // namespace mds::render
