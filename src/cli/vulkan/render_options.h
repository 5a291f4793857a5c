// The rendering options shared by `render`, `view` and `stress`: the culling loop of paper 000
// (docs/culling-math.md) and the sprite path (docs/rendering.md) -- one set of names, defaults,
// help texts and checks, as cli/vulkan/stream_options.h is for the streaming cache.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/result.h"
#include "render/ambient_occlusion_setup.h"
#include "render/cell_lines.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "store/slice.h"
#include "store/threshold.h"
#include "store/type_style.h"

namespace mds::cli {

struct CullingOptions {
  bool no_cull = false;
  std::string acceptance = "normal";  // normal (Eq. 21) | random (50:50 coin, paper Table 4)
  double cocc = MDS_CULL_C_OCC_DEFAULT;
  uint32_t budget = 0;  // occluder meshlets per sampling pass (0: automatic)
  double max_resident_share = render::culling::kDefaultMaxResidentShare;  // CullSettings::max_resident_share
  uint32_t samples_per_iteration = render::culling::kDefaultSamplesPerIteration;
  uint32_t converge_iterations = render::culling::kDefaultConvergeIterations;
  uint32_t max_iterations = render::culling::kDefaultMaxIterations;
  uint32_t bins = 0;
  uint32_t histogram_stride = render::culling::CullSettings{}.histogram_stride;  // histogram bins per pixel (0: as many as fit)
  uint32_t n_budget = MDS_CULL_N_BUDGET_DEFAULT;
  uint32_t seed = 1;
  std::string mesh_shaders = "auto";
  std::string coverage = "auto";           // auto | expected | exact (CullSettings::coverage)
  std::string particle_occlusion = "auto";  // auto | on | off (RenderSettings::particle_occlusion; auto: on with exact)
  bool pace_sampling = true;                // RenderSettings::pace_sampling
};

// Adds --no-cull (with this command's help text) and the culling and sprite-path options;
// --coverage only with coverage_option (bench has its own list of coverages).
void add_culling_options(CLI::App& sub, CullingOptions& o, const std::string& no_cull_help,
                         bool coverage_option = true);
// Sets rs.cull, rs.cull_settings and rs.mesh_shaders; Errc::invalid_argument naming the option
// for a bad value.
Status apply_culling_options(const CullingOptions& o, render::RenderSettings& rs);

// The look of the image, shared by `render`, `view` and `bench`: the background, the colour of
// each particle type (store/type_style.h) and the types left out.
struct AppearanceOptions {
  std::string background = "0.12,0.12,0.13";  // --background r,g,b, #rrggbb or transparent
  std::vector<std::string> type_colors;        // --type-color TYPE=COLOR, once per type
  std::vector<std::string> type_radii;         // --type-radius TYPE=R (in memory only)
  std::vector<std::string> hide_types;         // --hide-type TYPE (in memory only)
  std::vector<std::string> slices;             // --slice NX,NY,NZ,D[,WIDTH][,invert] (in memory only)
  std::string threshold;                       // --threshold LO:HI[,invert] (in memory only)
  std::string color_by = "auto";               // --color-by auto|type|color|x|y|z|property|NAME
  std::string color_range;                     // --color-range LO:HI (default: the data's bounds)
  std::string colormap = "viridis";            // --colormap (render::Colormap)
  std::string ao = "off";                      // --ao off|on|auto (shading/ambient_occlusion.h)
  double ao_radius = 0.0;                      // --ao-radius (0: 3 x the largest particle radius)
  double ao_strength = 1.0;                    // --ao-strength
  std::string cell = "auto";                   // --cell off|on|auto (render/cell_lines.h)
  std::string cell_color = "0.75,0.75,0.75";   // --cell-color r,g,b or #rrggbb
  float cell_width = 1.5f;                     // --cell-width, pixels
};

struct Appearance {
  glm::vec3 background_srgb{0.0f};
  bool transparent = false;  // --background transparent: black, and PNGs with alpha (render/image_io.h)
  std::vector<store::TypeColorSpec> type_colors;
  std::vector<store::TypeRadiusSpec> type_radii;
  std::vector<std::string> hide_types;  // type keys (store::find_type)
  std::vector<store::Slice> slices;     // --slice
  std::optional<store::Threshold> threshold;  // --threshold
  render::ColorBy color_by;             // --color-by, --color-range, --colormap
  shading::AoSettings ao;               // --ao, --ao-radius, --ao-strength
  render::CellMode cell = render::CellMode::automatic;  // --cell
  glm::vec3 cell_color_srgb{0.75f};     // --cell-color
  float cell_width_px = 1.5f;           // --cell-width
};

// Adds --background, --color-by, --color-range, and --type-color, --type-radius, --hide-type and
// --slice (repeatable).
void add_appearance_options(CLI::App& sub, AppearanceOptions& o);
// Parses both without the store (a bad colour fails before any Vulkan work);
// Errc::invalid_argument naming the option.
Result<Appearance> parse_appearance_options(const AppearanceOptions& o);
// Sets rs.background_srgb, rs.color_by and rs.type_colors_srgb, the colours resolved against the store's
// types; Errc::invalid_argument naming --type-color for a key that names no type.
// Also resolves --color-by NAME against the store's property (render::resolve_color_by), and
// --ao against the store (rs.ao_radius, rs.ao_strength; what was chosen in *ao when given), and
// --cell (rs.cell: the store's cell unless off; --cell on without one is Errc::invalid_argument).
Status apply_appearance(const Appearance& a, const store::StoreReader& reader, render::RenderSettings& rs,
                        render::AoChoice* ao = nullptr);
// What render::load_scene keeps and how large it draws it (--hide-type, --type-radius, --slice,
// --threshold):
// render::resolve_scene_options.
Result<render::SceneOptions> scene_options(const Appearance& a, const store::StoreReader& reader, bool streaming);

}  // namespace mds::cli
