// Colour by coordinate: viridis and the view-space plane of the colormap coordinate
// (render/colormap.h; mirrored by shaders/include/particle_color.h).
#include "render/colormap.h"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace mds::render {

glm::dvec3 viridis_srgb(double t) {
  // The coefficients of shaders/include/particle_color.h mds_viridis_srgb, in the same order.
  static const glm::dvec3 c[7] = {
      {0.2777273272234177, 0.005407344544966578, 0.3340998053353061},
      {0.1050930431085774, 1.404613529898575, 1.384590162594685},
      {-0.3308618287255563, 0.214847559468213, 0.09509516302823659},
      {-4.634230498983486, -5.799100973351585, -19.33244095627987},
      {6.228269936347081, 14.17993336680509, 56.69055260068105},
      {4.776384997670288, -13.74514537774601, -65.35303263337234},
      {-5.435455855934631, 4.645852612178535, 26.3124352495832},
  };
  t = std::clamp(t, 0.0, 1.0);
  glm::dvec3 v = c[6];
  for (int k = 5; k >= 0; --k) v = c[k] + t * v;  // Horner, as the shader
  return glm::clamp(v, glm::dvec3(0.0), glm::dvec3(1.0));
}

Result<int> parse_color_axis(std::string_view s) {
  if (s == "type") return -1;
  if (s == "x") return 0;
  if (s == "y") return 1;
  if (s == "z") return 2;
  if (s == "property") return kColorByProperty;
  return make_error(Errc::invalid_argument, "'{}': expected type, x, y, z or property", s);
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
  static const char* names[5] = {"type", "x", "y", "z", "property"};
  return names[std::clamp(axis + 1, 0, 4)];
}

glm::dvec4 color_plane(const glm::dmat4& view, const glm::dvec3& origin, int axis, double lo, double hi) {
  // p_world = origin + inverse(view) * p_view; t = (p_world[axis] - lo) / (hi - lo). Row `axis`
  // of the inverse (glm: m[column][row]) gives p_world[axis] - origin[axis] as an affine form.
  const glm::dmat4 inv = glm::inverse(view);
  const double s = 1.0 / (hi - lo);
  return {inv[0][axis] * s, inv[1][axis] * s, inv[2][axis] * s, (inv[3][axis] + origin[axis] - lo) * s};
}

Status resolve_color_by(ColorBy& c, const char* property_name, bool has_property, const std::string& store_name) {
  if (c.axis != kColorByName) return {};
  if (has_property && c.name == property_name) {
    c.axis = kColorByProperty;
    return {};
  }
  return make_error(Errc::invalid_argument, "--color-by '{}': expected type, x, y, z, property or {}", c.name,
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
