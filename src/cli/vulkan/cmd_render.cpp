// `mdstream render STORE -o IMAGE.png|.exr --no-cull [options]`: headless Vulkan rendering of a
// store as ray-cast sphere glyphs with progressive super-sampling, with the probabilistic
// occlusion culling loop of paper 000 (render/culling/cull_loop.h), or every particle with
// --no-cull (the reference). STORE may be a series index (.series, store/series.h): each frame
// of --series-frames is rendered as one store, through one Vulkan context, with one camera
// and one colour range for all of them (render/series_look.h).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/text_file.h"
#include "cli/command.h"
#include "cli/vulkan/render_options.h"
#include "cli/vulkan/node_log.h"
#include "cli/vulkan/render_path.h"
#include "cli/vulkan/stream_options.h"
#include "core/byte_size.h"
#include "culling/culling_constants.h"
#include "render/camera.h"
#include "render/culling/cull_loop.h"
#include "render/image_io.h"
#include "render/pick.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render/series_look.h"
#include "core/frame_selection.h"
#include "store/series.h"
#include "render/visible_nodes.h"
#include "overlay/color_legend.h"
#include "overlay/image_panels.h"
#include "store/store_reader.h"
#include "vk/context.h"

namespace mds::cli {
namespace {

struct RenderOptions {
  std::string store;
  std::string output;
  std::string stats;
  std::string camera;
  AppearanceOptions look;  // --background, --type-color, --type-radius, --hide-type
  int view = 0;
  bool ortho = false;
  CullingOptions cull;
  double fov = 40.0;
  uint32_t width = 1920, height = 1080, spp = 64;
  int device = -1;
  StreamOptions stream;  // --gpu-budget empty: in memory
  bool visible_reference = false;
  uint32_t paired_frames = 0;
  std::string path;           // --path: a built-in camera path or a path file (render_path.h)
  uint32_t path_frames = 60;  // --frames of a built-in path
  std::string series_frames = "all";  // --series-frames of a .series STORE
  std::vector<std::string> picks;     // --pick X,Y: the particle a pixel shows (render/pick.h)
  std::string node_log;               // --node-log CSV (write_node_log)
  std::string color_legend = "off";   // --color-legend CORNER (overlay/color_legend.h)
  std::string label;                  // --label TEXT with placeholders (overlay/text_label.h)
  std::string label_corner = "top-left";  // --label-corner CORNER
  std::string axes = "off";               // --axes CORNER: the coordinate tripod (overlay/axis_tripod.h)
};

// What a series render fixes for every frame (run_render_series); empty for one store.
struct FrameSetup {
  std::optional<render::Camera> camera;        // the series' camera (else --camera or --view)
  const render::SeriesLook* look = nullptr;    // the colour range over every frame
  std::optional<render::AoChoice> ao;          // the first frame's --ao choice, kept for the others
  render::AoChoice* ao_out = nullptr;          // receives this frame's choice
  // Streaming: the view of the frame before (StreamSettings::prior, with --series-first-wave
  // prior), and where this frame's goes.
  std::shared_ptr<const streaming::PriorView> prior;
  std::shared_ptr<const streaming::PriorView>* prior_out = nullptr;
  std::optional<int64_t> series_frame;  // the series index of the frame (--pick answers name it)
  std::optional<double> time;           // the series frame's time (--label's {time})
};

// What a streaming cache that reads whole nodes would read for this converged view, at two
// granularities of the classification it reads by (compressed payload bytes): nodes whose own
// class is not O (classified by their boxes: what the cache reads, docs/streaming.md), nodes
// with a meshlet not in O (what it would read if it could classify meshlets it has not loaded),
// and the nodes holding a visible particle (issue 4's reference). In memory only: every meshlet
// is classified and draws as an occluder, so these are the classes with the whole store resident.
struct NodeGranularity {
  uint64_t visible_nodes = 0, visible_bytes = 0;
  uint64_t node_kept_nodes = 0, node_kept_bytes = 0;
  uint64_t meshlet_kept_nodes = 0, meshlet_kept_bytes = 0;
};

NodeGranularity node_granularity(const store::StoreReader& reader, std::span<const uint32_t> node_classes,
                                 std::span<const uint32_t> meshlet_classes, std::span<const uint8_t> visible_nodes) {
  NodeGranularity g;
  const auto& nodes = reader.nodes();
  for (size_t i = 0; i < nodes.size(); ++i) {
    const uint64_t bytes = nodes[i].payload_bytes;
    if (i < visible_nodes.size() && visible_nodes[i]) {
      ++g.visible_nodes;
      g.visible_bytes += bytes;
    }
    if (i < node_classes.size() && node_classes[i] != uint32_t(MDS_CULL_CLASS_O)) {
      ++g.node_kept_nodes;
      g.node_kept_bytes += bytes;
    }
    bool kept = false;
    for (uint64_t m = nodes[i].first_meshlet; m < nodes[i].first_meshlet + nodes[i].meshlet_count && !kept; ++m)
      kept = m < meshlet_classes.size() && meshlet_classes[m] != uint32_t(MDS_CULL_CLASS_O);
    if (kept) {
      ++g.meshlet_kept_nodes;
      g.meshlet_kept_bytes += bytes;
    }
  }
  return g;
}

// The legend of what the image's colours mean (--color-legend): the colormap over the renderer's
// colour range, titled by the axis or the property's name, or the drawn types and their colours.
overlay::ColorLegend color_legend(const render::RenderSettings& rs, const render::Renderer& renderer,
                                  const store::StoreReader& reader, std::span<const uint8_t> shown) {
  overlay::ColorLegend l;
  if (rs.color_by.by_type()) {
    l.title = "type";
    l.entries = overlay::type_legend(reader.types(), rs.type_colors_srgb, shown);
  } else {
    l.colormap = true;
    l.title = rs.color_by.by_property() ? std::string(reader.header().property_name)
                                        : render::color_axis_name(rs.color_by.axis);
    l.range = renderer.color_range();
    l.map = rs.color_by.map;
  }
  return l;
}

nlohmann::json vec3_json(const glm::dvec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); }

// The pixels of --pick, each inside the image: checked before anything is rendered.
Result<std::vector<glm::uvec2>> pick_pixels(const RenderOptions& o) {
  std::vector<glm::uvec2> out;
  for (const std::string& spec : o.picks) {
    auto px = render::parse_pick_pixel(spec);
    if (!px) return make_error(Errc::invalid_argument, "--pick {}", px.error().message);
    if (px->x >= o.width || px->y >= o.height)
      return make_error(Errc::invalid_argument, "--pick {}: outside the {}x{} image", spec, o.width, o.height);
    out.push_back(*px);
  }
  return out;
}

// One --pick answer: the pixel (and the series frame), and the particle or null.
nlohmann::json pick_json(const store::StoreReader& reader, glm::uvec2 pixel, std::optional<int64_t> series_frame,
                         const std::optional<render::PickedParticle>& p) {
  nlohmann::json j;
  j["pixel"] = {pixel.x, pixel.y};
  if (series_frame) j["series_frame"] = *series_frame;
  if (!p) {
    j["particle"] = nullptr;
    return j;
  }
  const store::TypeEntry& t = reader.types()[p->type];
  nlohmann::json q = {{"node", p->node},
                      {"index_in_node", p->index_in_node},
                      {"index", p->index},
                      {"meshlet", p->meshlet},
                      {"type", p->type},
                      {"type_id", t.input_id},
                      {"type_name", std::string(t.name, strnlen(t.name, sizeof(t.name)))},
                      {"position", vec3_json(p->position)},
                      {"radius", p->radius},
                      {"hit", vec3_json(p->hit)},
                      {"distance", p->distance}};
  if (p->property) {
    const char* name = reader.header().property_name;
    q["property"] = {{"name", std::string(name, strnlen(name, store::kPropertyNameBytes))}, {"value", *p->property}};
  }
  if (p->color) q["color"] = render::color_hex(*p->color);
  j["particle"] = std::move(q);
  return j;
}

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}


// Renders o.store (one store) to o.output; the stats go to *stats_out when given, else to o.stats.
Status render_store(const RenderOptions& o, const FrameSetup& fs, std::unique_ptr<vk::Context>& ctx,
                    nlohmann::json* stats_out) {
  render::RenderSettings rs;
  MDS_TRY(apply_culling_options(o.cull, rs));
  if (o.fov <= 0.0 || o.fov >= 180.0)
    return make_error(Errc::invalid_argument, "--fov {}: expected degrees in (0, 180)", o.fov);
  MDS_ASSIGN_OR_RETURN(const Appearance look, parse_appearance_options(o.look));
  MDS_ASSIGN_OR_RETURN(const std::vector<glm::uvec2> picks, pick_pixels(o));
  auto corner = overlay::parse_legend_corner(o.color_legend);
  if (!corner.ok()) return make_error(Errc::invalid_argument, "--color-legend {}", corner.error().message);
  auto label_corner = overlay::parse_legend_corner(o.label_corner);
  if (!label_corner.ok() || *label_corner == overlay::LegendCorner::off)
    return make_error(Errc::invalid_argument, "--label-corner '{}': expected top-left, top-right, bottom-left or bottom-right",
                      o.label_corner);
  auto axes_corner = overlay::parse_legend_corner(o.axes);
  if (!axes_corner.ok()) return make_error(Errc::invalid_argument, "--axes {}", axes_corner.error().message);
  // --path: an animation (render_path.h). A path file is read before any other work.
  std::optional<render::BuiltinPath> builtin;
  render::CameraPath path;
  if (!o.path.empty()) {
    if (!o.camera.empty()) return make_error(Errc::invalid_argument, "--path and --camera: give one of them");
    if (o.visible_reference || o.paired_frames > 0 || !picks.empty() || !o.node_log.empty())
      return make_error(Errc::invalid_argument,
                        "--visible-reference, --paired-frames, --pick and --node-log ask about one view: not with --path");
    MDS_TRY(frame_file_name(o.output, 0));
    if (auto b = render::parse_builtin_path(o.path); b.ok()) {
      builtin = *b;
    } else {
      MDS_ASSIGN_OR_RETURN(path, render::CameraPath::load(o.path));
      if (path.empty()) return make_error(Errc::invalid_argument, "--path {}: no camera keyframes", o.path);
    }
  }
  const auto setup_start = std::chrono::steady_clock::now();  // stats "setup_ms"
  MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(o.store));
  // --label: expanded here, so that a bad placeholder is refused before any image is written.
  const overlay::LabelFields label_fields{fs.time, fs.series_frame.value_or(0), reader->header().particle_count,
                                          std::filesystem::path(o.store).filename().string()};
  std::string label;
  if (!o.label.empty()) {
    auto l = overlay::expand_label(o.label, label_fields);
    if (!l.ok()) return make_error(Errc::invalid_argument, "--label {}", l.error().message);
    label = std::move(*l);
  }
  render::AoChoice ao;
  Appearance frame_look = look;
  if (fs.look) {  // one choice for every frame
    frame_look.color_by = render::series_color_by(look.color_by, *fs.look);
    MDS_ASSIGN_OR_RETURN(frame_look.cell, render::series_cell_mode(look.cell, *fs.look, o.store));
  }
  MDS_TRY(apply_appearance(frame_look, *reader, rs, &ao));
  if (*corner != overlay::LegendCorner::off && rs.color_by.by_color())
    return make_error(Errc::invalid_argument,
                      "--color-legend: {} is drawn in its particles' own colours, which no legend explains (--color-by "
                      "type draws the types' colours)",
                      reader->path().string());
  if (fs.ao) {
    ao = *fs.ao;
    rs.ao_radius = ao.on ? ao.radius : 0.0;
    rs.ao_strength = ao.strength;
  }
  if (fs.ao_out) *fs.ao_out = ao;
  if (fs.look && !rs.color_by.by_type()) {
    const glm::dvec2 range = render::series_color_range(rs.color_by, *fs.look);
    rs.color_by.lo = range.x;
    rs.color_by.hi = range.y;
  }
  const bool streaming = !o.stream.gpu_budget.empty();
  MDS_ASSIGN_OR_RETURN(const render::SceneOptions so, scene_options(look, *reader, streaming));
  const std::vector<uint8_t>& shown = so.shown_types;
  if ((!shown.empty() || !so.type_radius.empty() || !so.slices.empty() || so.threshold) && o.visible_reference)
    return make_error(Errc::invalid_argument, "--visible-reference counts the store's particles at the store's radii: "
                      "not with --hide-type, --type-radius, --slice or --threshold");
  const bool drops_nodes = std::any_of(shown.begin(), shown.end(), [](uint8_t v) { return v == 0; }) ||
                           !so.slices.empty() || so.threshold.has_value();
  if (!streaming && drops_nodes && !o.node_log.empty())  // the scene's nodes no longer match the store's
    return make_error(Errc::invalid_argument, "--node-log lists the store's nodes: in memory not with --hide-type, "
                      "--slice or --threshold, which leave nodes out of the scene (streamed, --slice and --threshold are fine)");
  render::StreamSettings ss;
  if (streaming) {
    MDS_ASSIGN_OR_RETURN(ss, stream_settings(o.stream));
    ss.slices = so.slices;
    ss.threshold = so.threshold;
  }
  // In memory the whole store is decoded; streaming, only the directory is read here.
  render::SceneData scene;
  if (!streaming) {
    MDS_ASSIGN_OR_RETURN(scene, render::load_scene(*reader, so));
  } else {
    const auto& h = reader->header();
    std::vector<float> radii;
    for (const auto& t : reader->types()) radii.push_back(t.radius);
    scene = render::begin_scene({h.bounds_min[0], h.bounds_min[1], h.bounds_min[2]},
                                {h.bounds_max[0], h.bounds_max[1], h.bounds_max[2]}, radii,
                                (h.flags & store::kFlagPerParticleRadius) != 0, h.radius_min, h.radius_max);
  }

  render::Camera camera;
  const double aspect = double(o.width) / double(std::max(o.height, 1u));
  if (fs.camera) {
    camera = *fs.camera;
  } else if (!o.camera.empty()) {
    MDS_ASSIGN_OR_RETURN(camera, render::parse_camera(o.camera));
  } else {
    MDS_ASSIGN_OR_RETURN(camera, render::default_view(o.view, scene.bounds, o.fov, aspect));
  }
  camera.fov_y_deg = o.fov;
  camera.ortho = o.ortho;

  double context_ms = 0.0;
  if (!ctx) {
    const auto t = std::chrono::steady_clock::now();
    vk::ContextOptions copt = vk::ContextOptions::from_env();
    copt.device_index = o.device;
    MDS_ASSIGN_OR_RETURN(ctx, vk::Context::create(copt));
    context_ms = ms_since(t);
  }
  rs.width = o.width;
  rs.height = o.height;
  rs.spp = o.spp;
  rs.paired_frames = o.paired_frames;
  if (rs.cull) {
    MDS_ASSIGN_OR_RETURN(render::culling::DensityVolume vol, render::culling::density_from_store(*reader, scene));
    // With particles left out the store's counts include particles the scene lacks: its grid, the scene's counts.
    if (scene.left_out()) vol = render::culling::density_on_grid(scene, std::move(vol));
    rs.density = std::make_shared<const render::culling::DensityVolume>(std::move(vol));
  }
  // Setup: the store (decoded in memory, its directory streaming) and the density volume, then
  // the renderer (buffers, upload, pipelines: made once per process, vk/pipeline_cache.h).
  const double scene_ms = ms_since(setup_start) - context_ms;
  const vk::PipelineCache::Counts pipelines_before = ctx->pipelines().counts();
  const auto renderer_start = std::chrono::steady_clock::now();
  std::unique_ptr<render::Renderer> renderer;
  if (streaming) {
    if (ss.carry_view) ss.prior = fs.prior;
    MDS_ASSIGN_OR_RETURN(renderer, render::Renderer::create_streaming(*ctx, *reader, rs, ss));
  } else {
    MDS_ASSIGN_OR_RETURN(renderer, render::Renderer::create(*ctx, scene, rs));
  }
  const double renderer_ms = ms_since(renderer_start);
  const vk::PipelineCache::Counts pipelines_after = ctx->pipelines().counts();
  if (!o.path.empty()) {
    if (builtin) {
      path = render::builtin_path(*builtin, scene.bounds, o.path_frames, o.fov, aspect);
      if (o.ortho) {
        std::vector<render::CameraKey> keys = path.keys();
        for (auto& k : keys) k.camera.ortho = true;
        path = render::CameraPath(std::move(keys));
      }
    }
    PathRenderOptions po{o.output, o.stats, streaming, uint64_t(ctx->limits().maxStorageBufferRange)};
    po.panels.legend_corner = *corner;
    po.panels.legend = color_legend(rs, *renderer, *reader, shown);
    po.panels.label_corner = *label_corner;
    po.panels.axes_corner = *axes_corner;
    po.label_pattern = o.label;
    po.label_fields = label_fields;
    po.transparent = look.transparent;
    return render_path(*renderer, path, po);
  }
  render::RenderStats stats;
  MDS_ASSIGN_OR_RETURN(render::FrameImage image, renderer->render(camera, &stats));
  for (const std::string& e : stats.cache.errors) std::fprintf(stderr, "mdstream render: skipped node: %s\n", e.c_str());
  for (const std::string& w : cache_warnings(stats.cache, ctx->limits().maxStorageBufferRange))
    std::fprintf(stderr, "mdstream render: warning: %s\n", w.c_str());
  if (ao.on && !stats.ambient_occlusion)
    std::fprintf(stderr, "mdstream render: warning: --ao: drawn without ambient occlusion (it needs the visibility "
                         "route: a device with 64-bit buffer atomics)\n");
  // --pick: the particle each pixel shows, on stdout (a JSON object per line) and in the stats;
  // before the image is written, so that a node the pick cannot read leaves no image behind.
  nlohmann::json pick_answers = nlohmann::json::array();
  if (!picks.empty()) {
    render::Camera cam = camera;
    render::fit_clip_planes(cam, renderer->clip_bounds());
    for (const glm::uvec2 px : picks) {
      auto p = render::pick_particle(*reader, cam, o.width, o.height, glm::dvec2(px) + 0.5, so);
      if (!p.ok()) {
        Error e = p.error();
        e.message = fmt::format("--pick {},{}: {}: {}", px.x, px.y, o.store, e.message);
        return e;
      }
      pick_answers.push_back(pick_json(*reader, px, fs.series_frame, *p));
      std::printf("%s\n", pick_answers.back().dump().c_str());
    }
    std::fflush(stdout);
  }
  // The meshlets holding a visible particle of the last frame (render/visible_nodes.h): the
  // smallest set the culling could keep, the reference for the culled fraction.
  std::optional<render::VisibleSet> visible;
  std::optional<NodeGranularity> granularity;
  if (o.visible_reference) {
    MDS_ASSIGN_OR_RETURN(std::vector<float> depth, renderer->read_last_depth());
    render::Camera cam = camera;
    render::fit_clip_planes(cam, renderer->clip_bounds());
    MDS_ASSIGN_OR_RETURN(visible, render::visible_set(*reader, cam, renderer->width(), renderer->height(), depth, true));
    if (!streaming && renderer->cull_loop()) {
      MDS_ASSIGN_OR_RETURN(std::vector<uint32_t> mc, renderer->cull_loop()->read_meshlet_classes());
      granularity = node_granularity(*reader, renderer->cull_loop()->node_classes(), mc, visible->nodes);
    }
  }
  if (!o.node_log.empty())
    MDS_TRY(write_node_log(o.node_log, *reader, *renderer, visible ? std::span<const uint8_t>(visible->nodes)
                                                                   : std::span<const uint8_t>()));
  // The image last: a node log that cannot be written leaves no image behind (as a failed --pick).
  const overlay::PanelBoxes boxes = overlay::overlay_panels(
      image, {color_legend(rs, *renderer, *reader, shown), *corner, label, *label_corner, *axes_corner, camera});
  MDS_TRY(render::write_image(o.output, image, look.transparent));
  if (fs.prior_out) *fs.prior_out = renderer->prior_view();


  if (!o.stats.empty() || stats_out) {
    nlohmann::json j;
    j["store"] = o.store;
    j["output"] = o.output;
    j["device"] = stats.device;
    j["device_type"] = vk::device_type_name(ctx->info().type);
    j["mesh_shader_available"] = ctx->info().mesh_shader;
    j["sprite_path"] = stats.mesh_sprites ? "mesh" : "compute";
    j["pixel_route"] = stats.visibility_route ? "visibility" : "attachments";
    j["accumulation"] = stats.accumulation_buffer ? "buffer" : "image";
    if (*corner != overlay::LegendCorner::off)
      j["color_legend"] = {{"corner", overlay::legend_corner_name(*corner)},
                           {"box", {boxes.legend.x0, boxes.legend.y0, boxes.legend.x1, boxes.legend.y1}}};
    if (!label.empty())
      j["label"] = {{"text", label},
                    {"corner", overlay::legend_corner_name(*label_corner)},
                    {"box", {boxes.label.x0, boxes.label.y0, boxes.label.x1, boxes.label.y1}}};
    if (*axes_corner != overlay::LegendCorner::off)
      j["axes"] = {{"corner", overlay::legend_corner_name(*axes_corner)},
                   {"box", {boxes.axes.x0, boxes.axes.y0, boxes.axes.x1, boxes.axes.y1}}};
    j["ambient_occlusion"] = {{"mode", render::ao_mode_name(look.ao.mode)}, {"on", stats.ambient_occlusion},
                              {"radius", ao.radius},  {"strength", ao.strength}};
    if (ao.packing >= 0.0) j["ambient_occlusion"]["packing_fraction"] = ao.packing;
    j["resolve"] = stats.visibility_route ? (stats.covered_pixel_list ? "covered pixels" : "full screen") : "none";
    if (stats.covered_fraction >= 0.0) j["covered_fraction"] = stats.covered_fraction;  // the view's coverage probe
    j["particles"] = stats.particles;
    if (!stats.mesh_sprites)  // the last drawn frame's sprite pre-pass
      j["sprites"] = {{"listed", stats.sprites_listed},
                      {"offscreen", stats.sprites_offscreen},
                      {"compute_raster", stats.sprites_small}};
  if (!stats.mesh_sprites) j["sprite_chunks"] = stats.sprite_chunks;  // RenderSettings::sprite_capacity
    j["meshlets"] = stats.meshlets;
    j["nodes"] = streaming ? reader->nodes().size() : scene.nodes.size();  // hidden types may drop nodes
    j["spp"] = stats.spp;
    j["width"] = stats.width;
    j["height"] = stats.height;
    j["no_cull"] = o.cull.no_cull;
    j["view"] = o.camera.empty() ? o.view : -1;
    if (o.cull.no_cull) {
      j["frame_ms_no_cull"] = stats.frame_ms_median;
    } else {
      const auto& c = stats.cull;
      j["meshlets_culled"] = c.meshlets_culled;
      j["culled_fraction"] = stats.meshlets ? double(c.meshlets_culled) / double(stats.meshlets) : 0.0;
      j["iterations"] = c.iterations;
      j["iterations_after_spp"] = c.iterations_after_spp;
      j["samples"] = c.samples;
      j["iteration_ms_without_draw"] = c.iteration_ms_without_draw;
      j["iterations_to_converge"] = c.iterations_to_converge;
      j["samples_to_converge"] = c.samples_to_converge;
      j["converged"] = c.converged;
      j["frame_ms_during_culling"] = c.frame_ms_during_culling;
      j["frame_ms_after_convergence"] = c.frame_ms_after_convergence;
      j["pass_ms_after_convergence"] = c.pass_ms_after_convergence;
      j["time_to_converge_ms"] = c.time_to_converge_ms;
      j["particles_after_convergence"] = {{"listed", c.particles_listed}, {"occluded", c.particles_occluded}};
      if (c.paired_frames > 0) {
        j["paired_frames"] = c.paired_frames;
        j["frame_ms_paired_after_convergence"] = c.frame_ms_paired_culled;
        j["frame_ms_paired_no_cull"] = c.frame_ms_paired_all;
        j["speedup_paired"] = c.frame_ms_paired_culled > 0.0 ? c.frame_ms_paired_all / c.frame_ms_paired_culled : 0.0;
      }
      j["class_counts"] = {{"P", c.class_counts.size() == 4 ? c.class_counts[0] : 0},
                           {"L", c.class_counts.size() == 4 ? c.class_counts[1] : 0},
                           {"M", c.class_counts.size() == 4 ? c.class_counts[2] : 0},
                           {"O", c.class_counts.size() == 4 ? c.class_counts[3] : 0}};
      j["node_class_counts"] = {{"P", c.node_class_counts.size() == 4 ? c.node_class_counts[0] : 0},
                                {"L", c.node_class_counts.size() == 4 ? c.node_class_counts[1] : 0},
                                {"M", c.node_class_counts.size() == 4 ? c.node_class_counts[2] : 0},
                                {"O", c.node_class_counts.size() == 4 ? c.node_class_counts[3] : 0}};
      j["changed_per_iteration"] = c.changed_per_iteration;
      j["culled_per_iteration"] = c.culled_per_iteration;
      j["parameters"] = {{"cocc", o.cull.cocc},
                         {"acceptance", o.cull.acceptance},
                         {"occluder_budget", c.budget},
                         {"max_occluder_share", o.cull.max_resident_share},
                         {"converge_iterations", o.cull.converge_iterations},
                         {"samples_per_iteration", c.samples_per_iteration},
                         {"max_iterations", o.cull.max_iterations},
                         {"histogram_bins", c.bins},
                         {"histogram_stride", o.cull.histogram_stride},
                         {"sample_passes", {{"compute", c.sample_passes_compute},
                                            {"raster", c.sample_passes_raster}}},
                         {"sample_pass_ms_compared", {{"compute", c.sample_ms_compute},
                                                      {"raster", c.sample_ms_raster}}},
                         {"shared_box_tests", c.shared_box_tests},
                         {"node_per_subgroup", c.node_per_subgroup},
                         {"shared_cells", c.shared_cells},
                         {"n_budget", o.cull.n_budget},
                         {"seed", o.cull.seed},
                         {"mesh_shaders", o.cull.mesh_shaders},
                         {"coverage", o.cull.coverage},
                         {"particle_occlusion", rs.particle_occlusion ? "on" : "off"},
                         {"spp", stats.spp},
                         {"width", stats.width},
                         {"height", stats.height},
                         {"view", o.camera.empty() ? o.view : -1}};
    }
    if (streaming) {
      const auto& c = stats.cache;
      j["gpu_budget_bytes"] = c.gpu_budget_bytes;
      j["gpu_pool_bytes"] = c.pool_bytes;
      j["gpu_peak_bytes"] = c.gpu_peak_bytes;
      j["gpu_resident_bytes"] = c.resident_bytes;
      j["gpu_scratch_bytes"] = c.scratch_bytes;
      j["store_payload_bytes"] = c.store_payload_bytes;
      j["bytes_read"] = c.bytes_read;
      j["bytes_uploaded"] = c.bytes_uploaded;
      j["nodes_loaded"] = c.nodes_loaded;
      j["nodes_resident"] = c.nodes_resident;
      j["nodes_never_loaded"] = c.nodes_never_loaded;
      j["nodes_failed"] = c.nodes_failed;
      j["nodes_left_out"] = c.nodes_left_out;
      j["node_errors"] = c.errors;
      j["cache_hits"] = c.cache_hits;
      j["cache_misses"] = c.cache_misses;
      j["evictions"] = {{"P", c.evictions[0]}, {"L", c.evictions[1]}, {"M", c.evictions[2]}, {"O", c.evictions[3]}};
      j["upload_stalls"] = c.upload_stalls;
      j["late_arrivals_kept"] = c.late_arrivals_kept;
      j["budget_exhausted"] = c.budget_exhausted;
      j["gpu_pool_device_capped"] = c.pool_device_capped;
      j["wanted_nodes"] = c.wanted_nodes;
      j["wanted_bytes"] = c.wanted_bytes;
      j["frames_to_complete"] = c.frames_to_complete;
      j["ms_to_complete"] = c.ms_to_complete;
      j["prior_wanted_nodes"] = c.prior_wanted_nodes;
      j["carried_nodes"] = c.carried_nodes;
      j["policy"] = o.stream.policy;
      j["frames"] = stats.frames;
      j["frame_ms_p50"] = stats.frame_wall_ms_p50;
      j["frame_ms_p99"] = stats.frame_wall_ms_p99;
    }
    if (visible) {
      const auto count = [](const std::vector<uint8_t>& v) { return uint64_t(std::count(v.begin(), v.end(), 1)); };
      const uint64_t vm = count(visible->meshlets);
      j["visible_meshlets"] = vm;
      j["visible_nodes"] = count(visible->nodes);
      j["visible_meshlet_fraction"] = stats.meshlets ? double(vm) / double(stats.meshlets) : 0.0;
      if (!o.cull.no_cull)
        j["kept_over_visible_meshlets"] = vm ? double(stats.meshlets - stats.cull.meshlets_culled) / double(vm) : 0.0;
    }
    if (granularity) {
      const NodeGranularity& g = *granularity;
      const auto ratio = [&](uint64_t b) { return g.visible_bytes ? double(b) / double(g.visible_bytes) : 0.0; };
      j["node_granularity"] = {{"visible_nodes", g.visible_nodes},
                               {"visible_bytes", g.visible_bytes},
                               {"node_kept_nodes", g.node_kept_nodes},
                               {"node_kept_bytes", g.node_kept_bytes},
                               {"node_kept_over_visible", ratio(g.node_kept_bytes)},
                               {"meshlet_kept_nodes", g.meshlet_kept_nodes},
                               {"meshlet_kept_bytes", g.meshlet_kept_bytes},
                               {"meshlet_kept_over_visible", ratio(g.meshlet_kept_bytes)}};
    }
    j["pass_ms_median"] = stats.pass_ms_median;
    j["wall_ms"] = stats.wall_ms;
    j["setup_ms"] = {{"context", context_ms}, {"scene", scene_ms}, {"renderer", renderer_ms}};
    j["pipelines"] = {{"made", pipelines_after.pipelines - pipelines_before.pipelines},
                      {"reused", pipelines_after.reused - pipelines_before.reused}};
    j["upload_bytes"] = stats.upload_bytes;
    j["device_bytes_peak"] = stats.device_bytes;
    j["camera"] = {{"eye", vec3_json(camera.eye)},   {"target", vec3_json(camera.target)},
                   {"up", vec3_json(camera.up)},     {"fov_y_deg", camera.fov_y_deg},
                   {"ortho", camera.ortho},          {"near", stats.near},
                   {"far", stats.far},               {"view", o.camera.empty() ? o.view : -1}};
    j["background_srgb"] = {rs.background_srgb.r, rs.background_srgb.g, rs.background_srgb.b};
    j["transparent"] = look.transparent;  // --background transparent
    nlohmann::json type_colors = nlohmann::json::array();
    for (const glm::vec3& c : rs.type_colors_srgb) type_colors.push_back(store::srgb_hex({c.r, c.g, c.b}));
    j["type_colors_srgb"] = type_colors;
    if (!rs.color_by.by_type()) {  // the range as drawn (the data's bounds unless --color-range)
      const glm::dvec2 range = renderer->color_range();
      j["color_by"] = {{"axis", render::color_axis_name(rs.color_by.axis)}, {"range", {range.x, range.y}},
                       {"colormap", render::colormap_name(rs.color_by.map)}};
      if (rs.color_by.by_property()) j["color_by"]["property"] = std::string(reader->header().property_name);
    } else {
      j["color_by"] = {{"axis", rs.color_by.by_color() ? "color" : "type"}};
    }
    nlohmann::json hidden = nlohmann::json::array();
    for (size_t t = 0; t < shown.size(); ++t)
      if (!shown[t]) hidden.push_back(reader->types()[t].input_id);
    j["hidden_types"] = hidden;  // input ids
    nlohmann::json slices = nlohmann::json::array();
    for (const store::Slice& sl : so.slices) slices.push_back(store::slice_spec(sl));
    j["slices"] = slices;  // as --slice reads them, the normal unit length
    j["threshold"] = so.threshold ? nlohmann::json(store::threshold_spec(*so.threshold)) : nlohmann::json(nullptr);
    if (!so.type_radius.empty()) j["type_radius"] = so.type_radius;  // per type index, as drawn
    if (!picks.empty()) j["picks"] = pick_answers;
    j["validation"] = ctx->validation_enabled();
    j["validation_messages"] = ctx->validation_messages();
    if (stats_out) {
      *stats_out = std::move(j);
    } else {
      MDS_TRY(write_text_atomically(o.stats, j.dump(2) + "\n"));
    }
  }
  if (!o.cull.no_cull)
    std::fprintf(stderr, "mdstream render: culled %llu of %llu meshlets (%.1f %%), %s after %u iterations\n",
                 (unsigned long long)stats.cull.meshlets_culled, (unsigned long long)stats.meshlets,
                 stats.meshlets ? 100.0 * double(stats.cull.meshlets_culled) / double(stats.meshlets) : 0.0,
                 stats.cull.converged ? "converged" : "not converged", stats.cull.iterations);
  std::fprintf(stderr, "mdstream render: %s: %llu particles, %llu meshlets, %ux%u, %u spp, %.2f ms/pass (GPU), %s\n",
               o.output.c_str(), (unsigned long long)stats.particles, (unsigned long long)stats.meshlets, stats.width,
               stats.height, stats.spp, stats.frame_ms_median, stats.device.c_str());
  return {};
}

// A series: the frames of --series-frames, each rendered as a store with the series' camera
// (fixed, or --path's camera of that picture) and colour range; -o names them by series index
// when there are several (or it has a %d).
Status run_render_series(const RenderOptions& o) {
  if (!o.path.empty() && !o.camera.empty()) return make_error(Errc::invalid_argument, "--path and --camera: give one of them");
  if (o.paired_frames > 0)
    return make_error(Errc::invalid_argument, "--paired-frames measures one store: not with a series ({})", o.store);
  MDS_ASSIGN_OR_RETURN(const store::Series series, store::read_series(o.store));
  auto sel = parse_frame_selection(o.series_frames);
  if (!sel.ok()) return make_error(Errc::invalid_argument, "--series-frames {}", sel.error().message);
  auto picked = select_frames(*sel, int64_t(series.frames.size()));
  if (!picked.ok()) return make_error(Errc::invalid_argument, "{}: --series-frames {}", o.store, picked.error().message);
  const bool numbered = picked->size() > 1 || o.output.find('%') != std::string::npos;
  if (numbered) MDS_TRY(frame_file_name(o.output, 0));
  // --node-log is named per frame like -o: with several frames, or a %d in its own name.
  const bool numbered_log = !o.node_log.empty() && (picked->size() > 1 || o.node_log.find('%') != std::string::npos);
  if (numbered_log) MDS_TRY(frame_file_name(o.node_log, 0, "--node-log"));
  MDS_ASSIGN_OR_RETURN(const render::SeriesLook look, render::series_look(series, *picked));
  if (o.look.color_by == "color" && !look.has_color)  // before any frame is written
    return make_error(Errc::invalid_argument,
                      "--color-by color: not every picked frame of {} has per-particle colours (convert them with "
                      "--color)",
                      o.store);
  if (!o.look.threshold.empty() && !look.has_property)  // before any frame is written
    return make_error(Errc::invalid_argument,
                      "--threshold: not every picked frame of {} has a per-particle property (convert them with "
                      "--property NAME)",
                      o.store);
  {  // --cell on needs a cell in every picked frame: refused before any frame is written
    auto cell_mode = render::parse_cell_mode(o.look.cell);
    if (cell_mode.ok()) MDS_TRY(render::series_cell_mode(*cell_mode, look, o.store));
  }
  if (o.fov <= 0.0 || o.fov >= 180.0)
    return make_error(Errc::invalid_argument, "--fov {}: expected degrees in (0, 180)", o.fov);
  render::Camera camera;
  if (!o.camera.empty()) {
    MDS_ASSIGN_OR_RETURN(camera, render::parse_camera(o.camera));
  } else {
    MDS_ASSIGN_OR_RETURN(camera, render::default_view(o.view, look.bounds, o.fov, double(o.width) / double(o.height)));
  }
  camera.fov_y_deg = o.fov;
  camera.ortho = o.ortho;
  // --path: the camera moves as the frames go: picked frame i takes the path's frame i (a
  // built-in path has one frame per picked frame; a path file's last camera holds after its end).
  std::optional<render::CameraPath> path;
  if (!o.path.empty()) {
    if (auto b = render::parse_builtin_path(o.path); b.ok()) {
      path = render::builtin_path(*b, look.bounds, uint32_t(picked->size()), o.fov,
                                  double(o.width) / double(o.height));
    } else {
      MDS_ASSIGN_OR_RETURN(path, render::CameraPath::load(o.path));
      if (path->empty()) return make_error(Errc::invalid_argument, "--path {}: no camera keyframes", o.path);
    }
  }

  std::unique_ptr<vk::Context> ctx;
  FrameSetup fs;
  fs.camera = camera;
  fs.look = &look;
  render::AoChoice first_ao;
  std::shared_ptr<const streaming::PriorView> prior;  // streaming: the view of the frame before
  fs.prior_out = &prior;
  nlohmann::json frames = nlohmann::json::array();
  for (size_t i = 0; i < picked->size(); ++i) {
    const int64_t k = (*picked)[i];
    const store::SeriesFrame& f = series.frames[size_t(k)];
    RenderOptions fo = o;
    fo.store = f.path.string();
    fo.path.clear();  // the camera comes from fs
    if (numbered) {
      MDS_ASSIGN_OR_RETURN(fo.output, frame_file_name(o.output, uint32_t(k)));
    }
    if (numbered_log) {
      MDS_ASSIGN_OR_RETURN(fo.node_log, frame_file_name(o.node_log, uint32_t(k), "--node-log"));
    }
    fs.ao_out = i == 0 ? &first_ao : nullptr;
    if (path) {
      fs.camera = path->at(uint32_t(std::min<size_t>(i, path->frame_count() - 1)));
      if (o.ortho) fs.camera->ortho = true;
    }
    fs.prior = std::move(prior);
    fs.series_frame = k;
    fs.time = f.time;
    nlohmann::json fj;
    Status st = render_store(fo, fs, ctx, o.stats.empty() ? nullptr : &fj);
    if (!st.ok()) {
      Error e = st.error();
      e.message = fmt::format("{}: frame {} ({}): {}", o.store, k, f.name, e.message);
      return e;
    }
    if (i == 0) fs.ao = first_ao;
    if (!o.stats.empty()) {
      fj["series_frame"] = k;
      fj["time"] = f.time;
      frames.push_back(std::move(fj));
    }
  }
  if (!o.stats.empty()) {
    nlohmann::json j;
    j["series"] = o.store;
    j["series_frames"] = o.series_frames;
    j["frames"] = std::move(frames);
    MDS_TRY(write_text_atomically(o.stats, j.dump(2) + "\n"));
  }
  return {};
}

Status run_render(const RenderOptions& o) {
  if (store::is_series_path(o.store)) return run_render_series(o);
  std::unique_ptr<vk::Context> ctx;
  return render_store(o, {}, ctx, nullptr);
}

void setup_render(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<RenderOptions>();
  sub.add_option("store", opt->store, "Store file (.mds), or a series index (.series: see --series-frames)")->required();
  sub.add_option("-o,--output", opt->output, "Output image (.png: 8-bit sRGB; .exr: float linear RGBA)")->required();
  sub.add_option("--series-frames", opt->series_frames,
                 "Frames of a series to render: all, last, K, or a slice A:B[:S] (B exclusive, negative from the end). "
                 "One camera (--camera, or --view over the bounds of every picked frame) and one colour range (over "
                 "every picked frame unless --color-range) for all; with several frames -o names each by its series "
                 "index with a %d or %04d")
      ->capture_default_str();
  add_culling_options(sub, opt->cull, "Render every particle (no occlusion culling; the reference)");
  sub.add_option("--spp", opt->spp, "Jittered samples per pixel (progressive super-sampling)")
      ->check(CLI::Range(1u, 65536u))
      ->capture_default_str();
  sub.add_option("--width", opt->width, "Image width")->check(CLI::Range(1u, 16384u))->capture_default_str();
  sub.add_option("--height", opt->height, "Image height")->check(CLI::Range(1u, 16384u))->capture_default_str();
  sub.add_option("--camera", opt->camera, "ex,ey,ez,tx,ty,tz[,ux,uy,uz]: eye, target (and up) in data coordinates");
  sub.add_option("--view", opt->view,
                 "Default view from the bounds: 0 front (along -z), 1 oblique top, 2 close-up of a corner")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  sub.add_flag("--ortho", opt->ortho, "Orthographic projection (default perspective)");
  sub.add_option("--fov", opt->fov, "Vertical field of view in degrees (ortho: sets the height at the target)")
      ->capture_default_str();
  add_appearance_options(sub, opt->look);
  sub.add_option("--device", opt->device, "Vulkan device index (default: automatic, discrete GPU first)");
  sub.add_option("--stats", opt->stats, "Write statistics (counts, GPU pass times) as JSON");
  add_stream_options(sub, opt->stream, false, true);
  sub.add_flag("--visible-reference", opt->visible_reference,
               "Also compute, on the CPU, which meshlets hold a visible particle of the last frame "
               "(stats: visible_meshlets, visible_meshlet_fraction, kept_over_visible_meshlets)");
  sub.add_option("--color-legend", opt->color_legend,
                 "Draw what the colours mean into the image, in a corner: off, top-left, top-right, bottom-left or "
                 "bottom-right; the types and their colours, or with --color-by the colormap as a bar with its "
                 "values (OVITO's colour legend; docs/rendering.md, \"Colours, radii and hidden types\")")
      ->capture_default_str();
  sub.add_option("--label", opt->label,
                 "Draw a line of text into each image (OVITO's text label, ParaView's Annotate Time), with "
                 "placeholders in fmt's syntax: {time} (a series frame's time: its simulation step), {frame} (the "
                 "number -o's %d gets), {particles}, {store} (the file name); a format may follow a colon "
                 "({frame:04d}, {time:.1f}); e.g. \"step {time}\" (docs/rendering.md, \"Text label\")");
  sub.add_option("--label-corner", opt->label_corner,
                 "Where --label goes: top-left, top-right, bottom-left or bottom-right (after the colour legend when "
                 "both take one corner)")
      ->capture_default_str();
  sub.add_option("--axes", opt->axes,
                 "Draw the coordinate tripod (the data's x, y, z axes as the camera sees them: red, green, blue) in "
                 "a corner: off, top-left, top-right, bottom-left or bottom-right (OVITO's coordinate tripod, "
                 "ParaView's orientation axes; after the legend and the label in a shared corner)")
      ->capture_default_str();
  sub.add_option("--node-log", opt->node_log,
                 "Write one CSV row per node of the store after the last frame: its particles, payload bytes, "
                 "class and (with --visible-reference) whether it holds a visible particle; with --gpu-budget "
                 "also what the cache did: carried (a series step's first wave), read requests, the frame of the "
                 "first, loaded, resident, in the frustum, wanted. Several frames of a series: a %d in the name "
                 "(docs/streaming.md, \"Node log\")");
  sub.add_option("--path", opt->path,
                 "Render an animation: one image per frame of a camera path, a built-in one (orbit, flythrough, "
                 "jumps) or a path file (docs/camera-path.md); -o names the frames with %d or %04d "
                 "(frame_%04d.png); each frame converges, the GPU cache stays warm between frames. With a series "
                 "(.series) the camera moves as its frames go: picked frame i takes the path's frame i");
  sub.add_option("--pick", opt->picks,
                 "X,Y: name the particle pixel (X, Y) shows (0,0 top left; the ray through its centre; "
                 "repeatable): one JSON object per pixel on stdout and under \"picks\" in --stats, null where "
                 "no particle is hit (a series: per frame, with its series_frame). Answered on the CPU from the "
                 "store, as an unculled render shows it")
      ->type_name("X,Y");
  sub.add_option("--frames", opt->path_frames, "Frames of a built-in --path")
      ->check(CLI::Range(1u, 1000000u))
      ->capture_default_str();
  sub.add_option("--paired-frames", opt->paired_frames,
                 "In-memory culled renders: after convergence, this many frames of every meshlet and of the "
                 "potentially visible set, "
                 "alternately, without changing the image (stats: frame_ms_paired_*, speedup_paired: the "
                 "speed-up measured in one process, under the same load)")
      ->check(CLI::Range(0u, 1000u))
      ->capture_default_str();
  sub.callback([opt, &exit_code] {
    Status st = run_render(*opt);
    exit_code = st.ok() ? 0 : report("render", st.error());
  });
}

Registrar reg("render", "Render a store to an image (headless Vulkan, sphere glyphs)", setup_render);

}  // namespace
}  // namespace mds::cli
