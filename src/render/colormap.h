// Colour by coordinate (`--color-by x|y|z`, OVITO's "color coding" of a position component) or
// by the store's per-particle property (`--color-by property`: a LAMMPS column, an H5MD element,
// MMPLD intensity; `convert --property`): each particle takes the colour of t = (its value - lo)
// / (hi - lo), clamped to [0, 1], in the colormap of `--colormap` (viridis by default), instead
// of its type's colour. The double-precision originals of the shaders'
// shaders/include/particle_color.h (mds_colormap_srgb, mds_particle_color's plane).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include <glm/glm.hpp>

#include "core/result.h"

namespace mds::render {

// The colormaps of --colormap, in the order of render/colormap_table.h (its tables are
// matplotlib's, sampled by tools/gen_colormaps.py). viridis .. cividis: perceptually uniform,
// sequential; turbo: a rainbow (Google's); coolwarm: diverging, for signed quantities (Moreland);
// gray: black to white.
enum class Colormap : uint8_t { viridis, plasma, magma, inferno, cividis, turbo, coolwarm, gray };
// The name as --colormap takes it; parse_colormap's inverse (Errc::invalid_argument naming the
// choices otherwise).
const char* colormap_name(Colormap m);
Result<Colormap> parse_colormap(std::string_view s);

// Colormap m at t (clamped to [0, 1]) as sRGB in [0, 1]: the linear interpolation of its table
// 65 samples (colormap_sample), as mds_colormap_srgb does in float. Within 0.015 of
// matplotlib's 256-entry maps on every channel (ColorMap.EveryMapIsCloseToMatplotlib).
glm::dvec3 colormap_srgb(Colormap m, double t);
// Sample k (0..64) of map m's table, sRGB (FrameUniforms::colormap holds the 65 of the chosen map).
glm::dvec3 colormap_sample(Colormap m, unsigned k);
inline glm::dvec3 viridis_srgb(double t) { return colormap_srgb(Colormap::viridis, t); }

inline constexpr int kColorByProperty = 3;  // ColorBy::axis of --color-by property
inline constexpr int kColorByName = 4;      // --color-by NAME, until resolve_color_by finds the store's property
inline constexpr int kColorByColor = 5;     // --color-by color, until resolve_color_by checks the store's colours
inline constexpr int kColorByAuto = 6;      // --color-by auto (the default): color on a store with colours, else type

// What colours the particles: their type (axis -1), a world axis 0/1/2 or the property
// (kColorByProperty) over [lo, hi]; lo == hi (the default) takes the scene's bounds of the
// particle centres along the axis, or the store's property range.
struct ColorBy {
  int axis = -1;
  double lo = 0.0, hi = 0.0;
  Colormap map = Colormap::viridis;  // --colormap
  std::string name;  // with kColorByName: the property's name as given
  // With axis -1: the particles' own colours (store kFlagColor) instead of their types'.
  bool particle_colors = false;
  // No colormap: the types' colours or the particles' own (and, unresolved, color and auto).
  bool by_type() const { return axis < 0 || axis >= kColorByColor; }
  bool by_property() const { return axis == kColorByProperty; }
  bool by_color() const { return axis < 0 && particle_colors; }
};

// --color-by NAME (kColorByName) is the store's property when the store's property has that
// name (the name OVITO and ParaView users would type, e.g. c_pe): axis becomes kColorByProperty.
// Errc::invalid_argument naming the choices otherwise. --color-by color (kColorByColor) needs
// the store's colours, --color-by auto (kColorByAuto) takes them where the store has them; both
// become axis -1, with particle_colors set where the colours are drawn. Other axes are left as
// they are.
Status resolve_color_by(ColorBy& c, const char* property_name, bool has_property, bool has_color,
                        const std::string& store_name);

// "type", "x", "y", "z", "property", "color" or "auto"; Errc::invalid_argument otherwise.
Result<int> parse_color_axis(std::string_view s);
// "LO:HI" with LO < HI (finite numbers); Errc::invalid_argument otherwise.
Result<glm::dvec2> parse_color_range(std::string_view s);
std::string color_axis_name(int axis);  // "type", "x", "y", "z", "property", "color", "auto"

// The plane of FrameUniforms.color_plane: t = dot(plane.xyz, p_view) + plane.w for a view-space
// point p_view, where view maps (world - origin) to view space (camera.h view_matrix).
// Precondition: axis in 0..2, lo < hi.
glm::dvec4 color_plane(const glm::dmat4& view, const glm::dvec3& origin, int axis, double lo, double hi);

// The property's colour map as FrameUniforms.color_plane (x, w) = (scale, offset): t = scale *
// q + offset for a quantized value q in [0, 65535] of a store whose property spans [pmin, pmax]
// (store::property_value), t = (value - lo) / (hi - lo). Precondition: lo < hi.
glm::dvec2 property_color_map(double pmin, double pmax, double lo, double hi);
// The default --color-range of the property: [pmin, pmax], widened around a constant property
// (pmin == pmax) so that every particle maps to t = 0.5.
glm::dvec2 property_default_range(double pmin, double pmax);

}  // namespace mds::render
