// The rendering options shared by `render`, `view` and `stress`; see render_options.h.
#include "cli/vulkan/render_options.h"

#include "render/scene.h"

namespace mds::cli {

void add_culling_options(CLI::App& sub, CullingOptions& o, const std::string& no_cull_help, bool coverage_option) {
  sub.add_flag("--no-cull", o.no_cull, no_cull_help);
  sub.add_option("--acceptance", o.acceptance,
                 "Sample acceptance of Algorithm 1: normal (Eq. 21, normal approximation) or random (50:50 coin)")
      ->capture_default_str();
  sub.add_option("--cocc", o.cocc, "Confidence threshold of occlusion class O (paper: 0.95)")->capture_default_str();
  sub.add_option("--occluder-budget", o.budget,
                 "Occluder meshlets drawn per occlusion sampling pass (0: max(2 per node, meshlets / " +
                     std::to_string(render::culling::kDefaultBudgetDivisor) + "))")
      ->capture_default_str();
  sub.add_option("--max-occluder-share", o.max_resident_share,
                 "With --gpu-budget and the default --occluder-budget: at rest, while the pool fills (room for any "
                 "node, the view's nodes within it), an occlusion sampling pass draws at most this share of the resident meshlets (1: the default "
                 "budget alone, which while the cache fills draws every resident meshlet in every pass); "
                 "docs/streaming.md")
      ->check(CLI::Range(0.001, 1.0))
      ->capture_default_str();
  sub.add_option("--samples-per-iteration", o.samples_per_iteration,
                 "Occlusion sampling passes (one depth sample per pixel each) per culling iteration")
      ->check(CLI::Range(1u, 64u))
      ->capture_default_str();
  sub.add_option("--max-iterations", o.max_iterations,
                 "Culling iterations per view at most (render: past --spp culling continues alone until converged "
                 "or this cap)")
      ->check(CLI::Range(1u, 100000u))
      ->capture_default_str();
  sub.add_option("--converge-iterations", o.converge_iterations,
                 "Culling has converged after this many iterations without class changes (of "
                 "--samples-per-iteration passes: paced iterations at rest count their passes)")
      ->check(CLI::Range(1u, 1000000u))
      ->capture_default_str();
  sub.add_option("--histogram-bins", o.bins, "Density histogram bins per pixel (0: as many as fit, <= 64)")
      ->check(CLI::Range(0u, 64u))
      ->capture_default_str();
  sub.add_option("--histogram-stride", o.histogram_stride,
                 "Pixels per side of a density histogram block (one histogram cast along the block centre's ray "
                 "serves s x s pixels; 1 = per pixel, as the paper); docs/culling-math.md")
      ->check(CLI::Range(1u, 8u))
      ->capture_default_str();
  sub.add_option("--n-budget", o.n_budget, "N_budget of Eq. 21 (samples we are willing to wait for)")
      ->check(CLI::Range(1u, 1000000u))
      ->capture_default_str();
  sub.add_option("--seed", o.seed, "Random seed of occluder selection and sample acceptance")->capture_default_str();
  sub.add_option("--mesh-shaders", o.mesh_shaders,
                 "Sprite path: auto (compute + indirect draws, measured faster on a GPU; task/mesh shaders "
                 "where the device has VK_EXT_mesh_shader and MDSTREAM_PREFER_MESH=1), on (task/mesh shaders, "
                 "or an error), off (compute + indirect draws); docs/rendering.md")
      ->capture_default_str();
  if (coverage_option)
    sub.add_option("--coverage", o.coverage,
                   "Area of an occlusion sample's particle in its pixel (Sect. 4.1): expected (the paper's expected "
                   "area), exact (clipped against the pixel: fewer visible particles lost where particles are about "
                   "a pixel wide, less culling where they are large), or auto (per sample: exact where its particle "
                   "projects below 2 pixels, expected above); docs/culling-math.md")
        ->capture_default_str();
  sub.add_option("--particle-occlusion", o.particle_occlusion,
                 "After convergence also test each particle of the potentially visible set against the confidence "
                 "pyramid with the meshlet rule and skip those in class O: on, off (draw whole meshlets, as the "
                 "paper), or auto (on with --coverage exact only: with the expected area, also that of --coverage "
                 "auto's larger particles, it drops visible particles); docs/rendering.md")
      ->capture_default_str();
  sub.add_option("--pace-sampling", o.pace_sampling,
                 "Frame by frame (view, stress): at rest, a view whose occlusion sampling pass costs more than the "
                 "recent views' median runs fewer passes per culling iteration, so that its frames stay near the "
                 "usual length; convergence still needs as many quiet passes (true/false; docs/rendering.md, "
                 "\"Paced sampling at rest\")")
      ->capture_default_str();
}

Status apply_culling_options(const CullingOptions& o, render::RenderSettings& rs) {
  if (o.acceptance != "normal" && o.acceptance != "random")
    return make_error(Errc::invalid_argument, "--acceptance '{}': expected normal or random", o.acceptance);
  if (!(o.cocc > 0.0 && o.cocc < 1.0)) return make_error(Errc::invalid_argument, "--cocc {}: expected (0, 1)", o.cocc);
  MDS_ASSIGN_OR_RETURN(rs.mesh_shaders, render::parse_mesh_shader_mode(o.mesh_shaders));
  const auto coverage = render::culling::parse_coverage(o.coverage);
  if (!coverage)
    return make_error(Errc::invalid_argument, "--coverage '{}': expected auto, expected or exact", o.coverage);
  if (o.particle_occlusion != "on" && o.particle_occlusion != "off" && o.particle_occlusion != "auto")
    return make_error(Errc::invalid_argument, "--particle-occlusion '{}': expected auto, on or off",
                      o.particle_occlusion);
  rs.particle_occlusion = o.particle_occlusion == "on" || (o.particle_occlusion == "auto" && o.coverage == "exact");
  rs.cull = !o.no_cull;
  rs.pace_sampling = o.pace_sampling;
  auto& c = rs.cull_settings;
  c.c_occ = o.cocc;
  c.acceptance = o.acceptance == "random" ? MDS_CULL_ACCEPT_RANDOM : MDS_CULL_ACCEPT_NORMAL;
  c.budget = o.budget;
  c.max_resident_share = o.max_resident_share;
  c.samples_per_iteration = o.samples_per_iteration;
  c.converge_iterations = o.converge_iterations;
  c.max_iterations = o.max_iterations;
  c.bins = o.bins;
  c.histogram_stride = o.histogram_stride;
  c.n_budget = o.n_budget;
  c.seed = o.seed;
  c.coverage = *coverage;
  return {};
}

void add_appearance_options(CLI::App& sub, AppearanceOptions& o) {
  sub.add_option("--background", o.background,
                 "Background colour r,g,b (sRGB, 0..1) or #rrggbb, or transparent (render: a PNG with an alpha "
                 "channel, an EXR with premultiplied alpha; the viewer shows it black)")
      ->capture_default_str();
  sub.add_option("--type-color", o.type_colors,
                 "Colour of a particle type, TYPE=COLOR: TYPE its name or input id as `mdstream info` lists them, "
                 "COLOR #rrggbb or r,g,b (sRGB, 0..1); once per type (default: a palette by type index)")
      ->allow_extra_args(false);
  sub.add_option("--type-radius", o.type_radii,
                 "Radius of a particle type, TYPE=R (its name or input id), instead of the store's; once per type "
                 "(the whole store in memory: not with --gpu-budget, nor on a store with per-particle radii)")
      ->allow_extra_args(false);
  sub.add_option("--color-by", o.color_by,
                 "Colour the particles by their type, their own colours (convert --color), a coordinate or the store's "
                 "per-particle property (convert --property): type, color, auto (color where the store has colours, "
                 "else type), x, y, z, property or the property's name (--colormap over --color-range)")
      ->capture_default_str();
  sub.add_option("--colormap", o.colormap,
                 "Colormap of --color-by x|y|z|property: viridis, plasma, magma, inferno, cividis (perceptually "
                 "uniform), turbo (a rainbow), coolwarm (diverging, for signed quantities) or gray; matplotlib's "
                 "maps (docs/rendering.md, \"Colours, radii and hidden types\")")
      ->capture_default_str();
  sub.add_option("--color-range", o.color_range,
                 "LO:HI, the values --color-by maps to the two ends of the colormap (world units or the property's; "
                 "beyond: clamped; default: the bounds of the particle centres, or the property's range)");
  sub.add_option("--hide-type", o.hide_types,
                 "Leave out the particles of a type (its name or input id), once per type: they are neither drawn "
                 "nor occlude (the whole store in memory: not with --gpu-budget)")
      ->allow_extra_args(false);
  sub.add_option("--slice", o.slices,
                 "NX,NY,NZ,D[,WIDTH][,invert]: leave out the particles on the positive side of the plane n.p = D "
                 "(n the unit normal, world units), or with WIDTH > 0 all but the slab of that thickness around it; "
                 "invert keeps the other part; once per slice, all applied; by the particle centre, as OVITO's Slice "
                 "(in memory, and streaming: nodes the slices leave out are never read)")
      ->allow_extra_args(false);
  sub.add_option("--threshold", o.threshold,
                 "LO:HI[,invert]: keep only the particles whose per-particle property (convert --property) lies in "
                 "[LO, HI] (an empty LO or HI: open on that side; invert keeps the others), as ParaView's Threshold; "
                 "the others are neither drawn nor occlude (in memory, and streaming: nodes whose property histogram "
                 "holds no kept value are never read)");
  sub.add_option("--ao", o.ao,
                 "Screen-space ambient occlusion (SAO) of the spheres: off, on, or auto (on where the store's "
                 "particles are densely packed: packing fraction >= 0.1); the visibility route only")
      ->capture_default_str();
  sub.add_option("--ao-radius", o.ao_radius,
                 "Ambient occlusion radius, world units (0: 3 x the largest particle radius)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub.add_option("--ao-strength", o.ao_strength, "Ambient occlusion strength (SAO's sigma; 0: none)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub.add_option("--cell", o.cell,
                 "Draw the simulation cell's edges (the box the input described: LAMMPS BOX BOUNDS, extended XYZ "
                 "Lattice, H5MD box, MMPLD bounding box), depth tested against the particles, as OVITO does: auto "
                 "(where the store has a cell), on (an error without one) or off")
      ->capture_default_str();
  sub.add_option("--cell-color", o.cell_color, "Colour of the cell's edges, r,g,b (sRGB, 0..1) or #rrggbb")
      ->capture_default_str();
  sub.add_option("--cell-width", o.cell_width, "Width of the cell's edges in pixels")
      ->check(CLI::Range(0.5f, 64.0f))
      ->capture_default_str();
}

Result<Appearance> parse_appearance_options(const AppearanceOptions& o) {
  Appearance a;
  if (o.background == "transparent" || o.background == "none") {
    a.transparent = true;
    a.background_srgb = glm::vec3(0.0f);  // the colour premultiplied by the coverage (render/image_io.h)
  } else {
    auto bg = store::parse_srgb(o.background);
    if (!bg) return make_error(Errc::invalid_argument, "--background {} (or transparent)", bg.error().message);
    a.background_srgb = {bg->r, bg->g, bg->b};
  }
  for (const std::string& t : o.type_colors) {
    auto spec = store::parse_type_color(t);
    if (!spec) return make_error(Errc::invalid_argument, "--type-color {}", spec.error().message);
    a.type_colors.push_back(std::move(*spec));
  }
  for (const std::string& t : o.type_radii) {
    auto spec = store::parse_type_radius(t);
    if (!spec) return make_error(Errc::invalid_argument, "--type-radius {}", spec.error().message);
    a.type_radii.push_back(std::move(*spec));
  }
  a.hide_types = o.hide_types;
  MDS_ASSIGN_OR_RETURN(a.slices, store::parse_slices(o.slices));
  if (!o.threshold.empty()) {
    auto t = store::parse_threshold(o.threshold);
    if (!t) return make_error(Errc::invalid_argument, "--threshold {}", t.error().message);
    a.threshold = *t;
  }
  auto axis = render::parse_color_axis(o.color_by);
  if (axis) {
    a.color_by.axis = *axis;
  } else if (!o.color_by.empty() && o.color_by.size() < store::kPropertyNameBytes &&
             o.color_by.find_first_of(" \t:=\"") == std::string::npos) {
    a.color_by.axis = render::kColorByName;  // the store's property by its name: resolved with the store
    a.color_by.name = o.color_by;
  } else {
    return make_error(Errc::invalid_argument, "--color-by {}", axis.error().message);
  }
  if (!o.color_range.empty()) {
    if (a.color_by.by_type()) return make_error(Errc::invalid_argument, "--color-range needs --color-by x, y, z or property");
    auto range = render::parse_color_range(o.color_range);
    if (!range) return make_error(Errc::invalid_argument, "--color-range {}", range.error().message);
    a.color_by.lo = range->x;
    a.color_by.hi = range->y;
  }
  auto map = render::parse_colormap(o.colormap);
  if (!map) return make_error(Errc::invalid_argument, "--colormap {}", map.error().message);
  if (*map != render::Colormap::viridis && a.color_by.by_type())
    return make_error(Errc::invalid_argument, "--colormap needs --color-by x, y, z or property");
  a.color_by.map = *map;
  MDS_ASSIGN_OR_RETURN(a.ao.mode, render::parse_ao_mode(o.ao));
  a.ao.radius = o.ao_radius;
  a.ao.strength = o.ao_strength;
  auto cell = render::parse_cell_mode(o.cell);
  if (!cell) return make_error(Errc::invalid_argument, "--cell {}", cell.error().message);
  a.cell = *cell;
  auto cc = store::parse_srgb(o.cell_color);
  if (!cc) return make_error(Errc::invalid_argument, "--cell-color {}", cc.error().message);
  a.cell_color_srgb = {cc->r, cc->g, cc->b};
  a.cell_width_px = o.cell_width;
  return a;
}

Status apply_appearance(const Appearance& a, const store::StoreReader& reader, render::RenderSettings& rs,
                        render::AoChoice* ao) {
  rs.background_srgb = a.background_srgb;
  rs.color_by = a.color_by;
  const store::FileHeader& h = reader.header();
  MDS_TRY(render::resolve_color_by(rs.color_by, h.property_name, (h.flags & store::kFlagProperty) != 0,
                                   (h.flags & store::kFlagColor) != 0, reader.path().string()));
  auto colors = render::resolve_type_colors(reader.types(), a.type_colors);
  if (!colors) return make_error(Errc::invalid_argument, "--type-color: {}", colors.error().message);
  rs.type_colors_srgb = std::move(*colors);
  MDS_ASSIGN_OR_RETURN(const render::AoChoice choice, render::resolve_ao(a.ao, reader));
  rs.ao_radius = choice.on ? choice.radius : 0.0;
  rs.ao_strength = choice.strength;
  if (ao) *ao = choice;
  MDS_ASSIGN_OR_RETURN(rs.cell, render::resolve_cell(a.cell, reader));
  rs.cell_color_srgb = a.cell_color_srgb;
  rs.cell_width_px = a.cell_width_px;
  return {};
}

Result<render::SceneOptions> scene_options(const Appearance& a, const store::StoreReader& reader, bool streaming) {
  return render::resolve_scene_options(reader, a.hide_types, a.type_radii, a.slices, streaming, a.threshold);
}

}  // namespace mds::cli
