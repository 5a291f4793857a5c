// `mdstream stress STORE --gpu-budget B --path orbit|flythrough|jumps|FILE [options]`: the
// cache-behaviour stress tests of issue 4. Replays a camera path (render/camera_path.h) through
// the streaming renderer (Renderer::create_streaming, one set_view() + step() per frame), holds
// the final camera until the view has converged (--settle-frames), and reports the online cache
// (hit rate, bytes read/uploaded, evictions by occlusion class, upload stalls, nodes never
// loaded), frame wall-time quantiles, convergence per held view, and, from the request trace
// (FrameReport::wanted), the offline Belady/MIN hit rate for the same budget as the bound
// (Belady 1966; streaming/belady.h), next to LRU and FIFO simulated on the same trace.
// Report logic: cli/vulkan/stress_report.h. Output: a table on stdout, --json and --csv files.
#include <chrono>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/text_file.h"
#include "cli/command.h"
#include "cli/vulkan/node_log.h"
#include "cli/vulkan/render_options.h"
#include "cli/vulkan/stream_options.h"
#include "cli/vulkan/stress_report.h"
#include "core/byte_size.h"
#include "render/camera.h"
#include "render/camera_path.h"
#include "render/frame_pacer.h"
#include "render/renderer.h"
#include "render/visible_nodes.h"
#include "store/slice.h"
#include "store/store_reader.h"
#include "store/threshold.h"
#include "streaming/belady.h"
#include "streaming/residency.h"
#include "vk/context.h"

namespace mds::cli {
namespace {

struct StressOptions {
  std::string store;
  StreamOptions stream;
  PacingOptions pacing;
  std::string path;
  uint32_t frames = 0;  // 0: 240 for built-in paths, the file's frame count for a file
  uint32_t settle_frames = 200;
  uint32_t converged_frames = 8;
  bool known_path = true;  // the cache is told the path's next views (Renderer::set_path_next)
  uint32_t width = 640, height = 360;
  double fov = 40.0;
  std::string csv, json, trace;
  std::string node_log;  // --node-log CSV after the run (node_log.h)
  CullingOptions cull;
  std::vector<std::string> slices;  // --slice specs (store/slice.h)
  std::string threshold;            // --threshold spec (store/threshold.h); empty: none
  int device = -1;
  bool quiet = false;
};


// The path: a built-in name, else a keyframe file. A name that is neither is a usage error.
struct PathChoice {
  int held_view = -1;  // "view0".."view2": default view N held for the whole run
  bool builtin = false;
  render::BuiltinPath kind = render::BuiltinPath::orbit;
  render::CameraPath file_path;
};

Result<PathChoice> choose_path(const std::string& spec) {
  PathChoice c;
  if (spec.size() == 5 && spec.rfind("view", 0) == 0 && spec[4] >= '0' && spec[4] <= '2') {
    c.held_view = spec[4] - '0';
    return c;
  }
  if (auto b = render::parse_builtin_path(spec); b.ok()) {
    c.builtin = true;
    c.kind = *b;
    return c;
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(spec, ec))
    return make_error(Errc::invalid_argument,
                      "--path '{}': not a built-in path (orbit, flythrough, jumps, view0..view2) and no such camera path file", spec);
  MDS_ASSIGN_OR_RETURN(c.file_path, render::CameraPath::load(spec));
  return c;
}

std::string fmt_bytes(uint64_t b) { return format_bytes(b); }
std::string fmt_rate(double r) { return fmt::format("{:.4f}", r); }

Status run_stress(const StressOptions& o) {
  // --- options (usage errors before any work) ---
  MDS_ASSIGN_OR_RETURN(render::StreamSettings ss, stream_settings(o.stream));
  ss.record_trace = true;
  MDS_ASSIGN_OR_RETURN(ss.slices, store::parse_slices(o.slices));
  if (!o.threshold.empty()) {
    auto t = store::parse_threshold(o.threshold);
    if (!t) return make_error(Errc::invalid_argument, "--threshold {}", t.error().message);
    ss.threshold = *t;
  }
  const uint64_t budget = ss.gpu_budget;
  const streaming::Policy policy = ss.policy;
  const uint64_t bandwidth = uint64_t(ss.io.io_bandwidth);
  const uint64_t upload_budget = ss.upload_bytes_per_frame;
  render::RenderSettings rs;
  MDS_TRY(apply_culling_options(o.cull, rs));
  if (o.fov <= 0.0 || o.fov >= 180.0)
    return make_error(Errc::invalid_argument, "--fov {}: expected degrees in (0, 180)", o.fov);
  MDS_ASSIGN_OR_RETURN(PathChoice choice, choose_path(o.path));
  MDS_ASSIGN_OR_RETURN(render::PacerSettings pacer_cfg, pacer_settings(o.pacing));
  std::optional<render::FramePacer> pacer;

  MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(o.store));
  vk::ContextOptions copt = vk::ContextOptions::from_env();
  copt.device_index = o.device;
  MDS_ASSIGN_OR_RETURN(auto ctx, vk::Context::create(copt));
  pacer_cfg.cpu_device = ctx->info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  if (o.pacing.dynamic) pacer.emplace(pacer_cfg);

  rs.width = o.width;
  rs.height = o.height;
  rs.spp = 65536;  // keep accumulating: every frame draws (converged-frame cost is a real frame)
  MDS_ASSIGN_OR_RETURN(auto renderer, render::Renderer::create_streaming(*ctx, *reader, rs, ss));

  const double aspect = double(o.width) / double(std::max(o.height, 1u));
  render::CameraPath path;
  std::string path_name;
  if (choice.held_view >= 0) {
    MDS_ASSIGN_OR_RETURN(render::Camera cam, render::default_view(choice.held_view, renderer->bounds(), o.fov, aspect));
    cam.ortho_half_height = 0.0;
    const uint32_t frames = o.frames ? o.frames : 240u;
    std::vector<render::CameraKey> keys{{0, cam}};
    if (frames > 1) keys.push_back({frames - 1, cam});
    path = render::CameraPath(std::move(keys));
    path_name = o.path;
  } else if (choice.builtin) {
    const uint32_t frames = o.frames ? o.frames : 240u;
    path = render::builtin_path(choice.kind, renderer->bounds(), frames, o.fov, aspect);
    path_name = render::builtin_path_name(choice.kind);
  } else {
    path = std::move(choice.file_path);
    path_name = o.path;
  }
  const uint32_t path_frames = o.frames ? o.frames : path.frame_count();

  // --- the replay ---
  const auto& nodes = reader->nodes();
  std::vector<stress::FrameRecord> frames;
  std::vector<streaming::TraceRequest> trace;
  std::vector<uint32_t> trace_frames;  // the replay frame of each request (--trace)
  std::vector<uint8_t> trace_hits;     // the online cache's outcome of each request (--trace)
  std::vector<uint64_t> device_bytes = renderer->node_device_bytes();
  uint32_t view = 0;
  render::Camera prev_cam;
  // The views after frame f of the replay: the path's next frames, then its final camera held
  // (the settle frames). Handed to the cache with --known-path (Renderer::set_path_next).
  const render::Camera final_cam = path.at(path_frames ? path_frames - 1 : 0);
  auto next_views = [&](uint32_t f) {
    std::vector<render::Camera> next;
    for (uint32_t k = 1; k <= render::Renderer::kPathNextViews; ++k)
      next.push_back(f + k < path_frames ? path.at(f + k) : final_cam);
    return next;
  };
  auto one_frame = [&](const render::Camera& cam, bool first, bool settle, bool after,
                       std::span<const render::Camera> next) -> Result<stress::FrameRecord> {
    const bool moving = first || !render::identical_cameras(cam, prev_cam);
    if (!first && moving) ++view;
    prev_cam = cam;
    // A frame's time is its own work: [resize (--dynamic-resolution)] + set_view (restarts the
    // culling state for a new camera) + step + finish (its GPU work), as a viewer frame that
    // shows its image. Without the finish a frame would pay for the previous one's GPU work,
    // and the pacer would judge each scale by the frame before it.
    const auto t0 = std::chrono::steady_clock::now();
    double scale = 1.0;
    if (pacer) {
      scale = pacer->next_scale(moving);
      uint32_t sw = 0, sh = 0;
      render::FramePacer::scaled_size(o.width, o.height, scale, sw, sh);
      MDS_TRY(renderer->resize(sw, sh));
    }
    // One occlusion sampling pass per iteration while moving, over the scale's share of the budget.
    renderer->set_motion(moving, pacer ? pacer->sample_share(o.width, o.height) : 1.0);
    if (o.known_path) renderer->set_path_next(next);
    using ms = std::chrono::duration<double, std::milli>;
    const auto t_view = std::chrono::steady_clock::now();
    MDS_TRY(renderer->set_view(cam));
    const auto t_step = std::chrono::steady_clock::now();
    MDS_ASSIGN_OR_RETURN(render::FrameReport fr, renderer->step());
    const auto t_finish = std::chrono::steady_clock::now();
    MDS_TRY(renderer->finish());
    const auto t_end = std::chrono::steady_clock::now();
    fr.wall_ms = ms(t_end - t0).count();
    // This frame's own GPU passes (finish() collected them; fr.gpu_ms is the previous frame's).
    const render::FrameGpu gpu = renderer->last_frame_gpu();
    if (pacer) pacer->observe(fr.wall_ms, fr.load(), gpu.ms);
    stress::FrameRecord r;
    r.scale = scale;
    r.view = view;
    r.settle = settle;
    r.after_converged = after;
    r.wall_ms = fr.wall_ms;
    r.gpu_ms = gpu.ms;
    r.gpu_passes = gpu.passes;
    r.resize_ms = ms(t_view - t0).count();  // the pacer's scale and Renderer::resize (with set_motion)
    r.sample_raster = fr.sample_passes_raster;
    r.sample_compute = fr.sample_passes_compute;
    r.sample_probe = fr.sample_probe;
    r.sample_probe_share = fr.sample_probe_share;
    r.compared_raster_ms = fr.sample_compared_ms_raster;
    r.compared_compute_ms = fr.sample_compared_ms_compute;
    r.view_ms = ms(t_step - t_view).count();
    r.step_ms = ms(t_finish - t_step).count();
    r.cache_ms = fr.cache_ms;
    r.finish_ms = ms(t_end - t_finish).count();
    r.converged = fr.converged;
    r.complete = fr.complete;
    r.upload_stall = fr.upload_stall;
    r.hits = fr.frame_hits;
    r.misses = fr.frame_misses;
    r.reads_requested = fr.reads_requested;
    r.upload_regions = fr.upload_regions;
    r.bytes_uploaded = fr.bytes_uploaded;
    r.bytes_read_total = renderer->stats().cache.bytes_read;
    r.wanted_nodes = uint32_t(fr.wanted.size());
    if (device_bytes.empty()) device_bytes = renderer->node_device_bytes();
    for (size_t k = 0; k < fr.wanted.size(); ++k) {
      const uint32_t n = fr.wanted[k];
      if (n < nodes.size()) r.wanted_payload_bytes += nodes[n].payload_bytes;
      trace.push_back({n, n < device_bytes.size() ? device_bytes[n] : 0});
      trace_frames.push_back(uint32_t(frames.size()));
      trace_hits.push_back(k < fr.wanted_hit.size() ? fr.wanted_hit[k] : 0);
    }
    return r;
  };
  const bool progress = !o.quiet && stderr_is_tty();
  for (uint32_t f = 0; f < path_frames; ++f) {
    MDS_ASSIGN_OR_RETURN(stress::FrameRecord r, one_frame(path.at(f), f == 0, false, false, next_views(f)));
    frames.push_back(r);
    if (progress && (f % 10 == 0 || f + 1 == path_frames))
      std::fprintf(stderr, "\rmdstream stress: frame %u/%u", f + 1, path_frames);
  }
  if (progress) std::fprintf(stderr, "\n");
  // Hold the final camera until its view has converged (at most --settle-frames more frames).
  const std::vector<render::Camera> held = next_views(path_frames);
  uint32_t settle_run = 0;
  bool final_converged = !frames.empty() && frames.back().converged;
  while (!final_converged && settle_run < o.settle_frames) {
    MDS_ASSIGN_OR_RETURN(stress::FrameRecord r, one_frame(final_cam, frames.empty(), true, false, held));
    frames.push_back(r);
    ++settle_run;
    final_converged = r.converged;
  }
  // Converged-frame cost: a few more frames of the converged final view.
  uint32_t converged_run = 0;
  std::vector<double> conv_wall, conv_gpu;
  if (final_converged) {
    for (; converged_run < o.converged_frames; ++converged_run) {
      MDS_ASSIGN_OR_RETURN(stress::FrameRecord r, one_frame(final_cam, false, true, true, held));
      frames.push_back(r);
      conv_wall.push_back(r.wall_ms);
      conv_gpu.push_back(r.gpu_ms);
    }
  }

  // The nodes holding a visible particle of the converged final view (render/visible_nodes.h),
  // from its last frame's depth: the reference of "bytes read to converge a dense view".
  std::optional<std::pair<uint64_t, uint64_t>> visible;  // nodes, compressed payload bytes
  std::vector<uint8_t> vis;                               // per node: visible (when converged)
  if (final_converged) {
    MDS_ASSIGN_OR_RETURN(std::vector<float> depth, renderer->read_last_depth());
    render::Camera cam = final_cam;
    render::fit_clip_planes(cam, renderer->bounds());
    MDS_ASSIGN_OR_RETURN(vis, render::visible_nodes(*reader, cam, renderer->width(), renderer->height(), depth));
    visible.emplace(0, 0);
    for (uint32_t i = 0; i < vis.size(); ++i)
      if (vis[i]) {
        ++visible->first;
        visible->second += reader->nodes()[i].payload_bytes;
      }
  }

  // --- report ---
  const render::RenderStats st = renderer->stats();
  const render::CacheStats& c = st.cache;
  // Each request at its node's size in the pool: the directory's, or, for a node that --slice
  // cuts, the pages of what it keeps (the cache learns it on the first read, so the requests
  // before it were recorded at the directory's larger size; cut nodes it never read are read and
  // thinned now). At the directory sizes the bounds' pool would hold fewer nodes than the cache's.
  MDS_ASSIGN_OR_RETURN(device_bytes, renderer->node_device_bytes_kept());
  for (auto& t : trace)
    if (t.node < device_bytes.size()) t.bytes = device_bytes[t.node];
  const uint64_t sim_budget = c.pool_bytes ? c.pool_bytes : budget;
  const stress::SimBounds bounds = stress::simulate_bounds(trace, sim_budget);
  const auto views = stress::summarize_views(frames);

  std::vector<double> path_ms, streaming_ms;
  for (const auto& f : frames) {
    if (!f.settle) path_ms.push_back(f.wall_ms);
    if (!f.after_converged && !f.complete) streaming_ms.push_back(f.wall_ms);
  }
  std::vector<double> all_ms;
  for (const auto& f : frames)
    if (!f.after_converged) all_ms.push_back(f.wall_ms);
  const auto q_path = stress::quantiles(path_ms), q_all = stress::quantiles(all_ms),
             q_stream = stress::quantiles(streaming_ms);
  const uint64_t requests = c.cache_hits + c.cache_misses;
  const double hit_rate = requests ? double(c.cache_hits) / double(requests) : 0.0;

  nlohmann::ordered_json j;
  j["store"] = o.store;
  j["store_file_bytes"] = reader->file_bytes();
  j["store_payload_bytes"] = reader->header().payload_bytes;
  j["particles"] = reader->header().particle_count;
  j["nodes"] = nodes.size();
  j["path"] = path_name;
  j["policy"] = streaming::policy_name(policy);
  j["cull"] = !o.cull.no_cull;
  j["width"] = o.width;
  j["height"] = o.height;
  j["frames"] = path_frames;
  j["known_path"] = o.known_path;
  {
    nlohmann::json slices = nlohmann::json::array();
    for (const store::Slice& sl : ss.slices) slices.push_back(store::slice_spec(sl));
    j["slices"] = slices;  // as --slice reads them (render --stats' keys)
    j["threshold"] = ss.threshold ? nlohmann::json(store::threshold_spec(*ss.threshold)) : nlohmann::json(nullptr);
  }
  {
    std::vector<double> path_scales;
    for (const auto& f : frames)
      if (!f.settle) path_scales.push_back(f.scale);
    j["dynamic_resolution"] = o.pacing.dynamic;
    j["frame_ms_target"] = pacer ? pacer->target_ms() : 0.0;  // automatic: the final value
    j["min_scale"] = pacer ? pacer->settings().min_scale : 1.0;
    j["pace_gpu_time"] = pacer && pacer->split_gpu_time();  // --pace-gpu-time, resolved for the device
    j["pace_samples"] = pacer && pacer->settings().scale_samples;  // --pace-samples
    j["scale_p50"] = stress::quantile(path_scales, 0.5);
    j["scale_min"] = path_scales.empty() ? 1.0 : *std::min_element(path_scales.begin(), path_scales.end());
  }
  j["settle_frames_run"] = settle_run;
  j["converged_frames_run"] = converged_run;
  j["frames_total"] = frames.size();
  j["device"] = st.device;
  j["device_type"] = vk::device_type_name(ctx->info().type);  // "cpu" on lavapipe
  j["cull_shared_box_tests"] = st.cull.shared_box_tests;  // cull_classify_coop.comp
  j["cull_node_per_subgroup"] = st.cull.node_per_subgroup;  // its push.mode 2
  j["cull_shared_cells"] = st.cull.shared_cells;  // kSharedCells
  j["io"] = {{"threads", ss.io.threads}, {"latency_ms", ss.io.io_latency_ms}, {"bandwidth_bytes_per_s", bandwidth}};
  j["upload_bytes_per_frame"] = upload_budget;
  j["gpu_budget_bytes"] = c.gpu_budget_bytes ? c.gpu_budget_bytes : budget;
  j["pool_bytes"] = c.pool_bytes;
  j["gpu_peak_bytes"] = c.gpu_peak_bytes;
  j["scratch_bytes"] = c.scratch_bytes;
  j["cache_hits"] = c.cache_hits;
  j["cache_misses"] = c.cache_misses;
  j["hit_rate"] = hit_rate;
  j["bytes_read"] = c.bytes_read;
  j["bytes_read_over_store"] =
      reader->header().payload_bytes ? double(c.bytes_read) / double(reader->header().payload_bytes) : 0.0;
  j["bytes_uploaded"] = c.bytes_uploaded;
  j["nodes_loaded"] = c.nodes_loaded;
  j["nodes_never_loaded"] = c.nodes_never_loaded;
  j["budget_exhausted"] = c.budget_exhausted;
  j["gpu_pool_device_capped"] = c.pool_device_capped;
  j["wanted_nodes"] = c.wanted_nodes;
  j["wanted_bytes"] = c.wanted_bytes;
  j["nodes_failed"] = c.nodes_failed;
  j["nodes_left_out"] = c.nodes_left_out;
  j["evictions"] = {{"O", c.evictions[3]}, {"M", c.evictions[2]}, {"L", c.evictions[1]}, {"P", c.evictions[0]}};
  j["upload_stalls"] = c.upload_stalls;
  j["late_arrivals_kept"] = c.late_arrivals_kept;
  j["frame_ms"] = stress::quantiles_json(q_path);
  j["frame_ms_with_settle"] = stress::quantiles_json(q_all);
  j["streaming_frame_ms"] = stress::quantiles_json(q_stream);
  j["converged_frame_ms"] = conv_wall.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(stress::quantile(conv_wall, 0.5));
  j["converged_frame_gpu_ms"] = conv_gpu.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(stress::quantile(conv_gpu, 0.5));
  uint32_t views_converged = 0;
  std::vector<double> conv_ms, conv_frames;
  for (const auto& v : views)
    if (v.converged) {
      ++views_converged;
      conv_ms.push_back(v.ms_to_converge);
      conv_frames.push_back(v.frames_to_converge);
    }
  j["views_held"] = views.size();
  j["views_converged"] = views_converged;
  j["convergence_ms"] = stress::quantiles_json(stress::quantiles(conv_ms));
  j["convergence_frames"] = stress::quantiles_json(stress::quantiles(conv_frames));
  const stress::ViewResult last = views.empty() ? stress::ViewResult{} : views.back();
  j["final_view"] = stress::view_json(last);
  j["final_view"]["bytes_read_over_wanted"] =
      last.converged && last.wanted_bytes_at_convergence
          ? nlohmann::ordered_json(double(last.bytes_read_to_converge) / double(last.wanted_bytes_at_convergence))
          : nlohmann::ordered_json(nullptr);
  j["final_view"]["visible_nodes"] = visible ? nlohmann::ordered_json(visible->first) : nlohmann::ordered_json(nullptr);
  j["final_view"]["visible_node_bytes"] = visible ? nlohmann::ordered_json(visible->second) : nlohmann::ordered_json(nullptr);
  j["final_view"]["bytes_read_over_visible"] =
      last.converged && visible && visible->second
          ? nlohmann::ordered_json(double(last.bytes_read_to_converge) / double(visible->second))
          : nlohmann::ordered_json(nullptr);
  j["bound"] = {{"budget_bytes", bounds.budget_bytes},
                {"requests", bounds.belady.requests},
                {"belady", stress::sim_json(bounds.belady)},
                {"belady_bypass", stress::sim_json(bounds.belady_bypass)},
                {"lru", stress::sim_json(bounds.lru)},
                {"fifo", stress::sim_json(bounds.fifo)}};
  j["hit_rate_over_belady"] = bounds.belady.hit_rate() > 0.0 ? hit_rate / bounds.belady.hit_rate() : 0.0;
  nlohmann::ordered_json jv = nlohmann::ordered_json::array();
  for (const auto& v : views) jv.push_back(stress::view_json(v));
  j["views"] = jv;
  j["errors"] = c.errors;
  nlohmann::ordered_json pf = {{"wall_ms", nlohmann::ordered_json::array()}, {"gpu_ms", nlohmann::ordered_json::array()},
                               {"view", nlohmann::ordered_json::array()},    {"settle", nlohmann::ordered_json::array()},
                               {"complete", nlohmann::ordered_json::array()}, {"converged", nlohmann::ordered_json::array()},
                               {"hits", nlohmann::ordered_json::array()},    {"misses", nlohmann::ordered_json::array()},
                               {"reads_requested", nlohmann::ordered_json::array()},
                               {"upload_regions", nlohmann::ordered_json::array()},
                               {"bytes_read_total", nlohmann::ordered_json::array()},
                               {"scale", nlohmann::ordered_json::array()},
                               {"gpu_passes", nlohmann::ordered_json::array()},
                               {"cpu_parts", nlohmann::ordered_json::array()},
                               {"sample_route", nlohmann::ordered_json::array()}};
  for (const auto& f : frames) {
    pf["wall_ms"].push_back(f.wall_ms);
    pf["gpu_ms"].push_back(f.gpu_ms);
    pf["view"].push_back(f.view);
    pf["settle"].push_back(f.settle);
    pf["complete"].push_back(f.complete);
    pf["converged"].push_back(f.converged);
    pf["hits"].push_back(f.hits);
    pf["misses"].push_back(f.misses);
    pf["reads_requested"].push_back(f.reads_requested);
    pf["upload_regions"].push_back(f.upload_regions);
    pf["bytes_read_total"].push_back(f.bytes_read_total);
    pf["scale"].push_back(f.scale);
    pf["gpu_passes"].push_back(f.gpu_passes);  // pass -> GPU ms of this frame (summed over repeats)
    pf["cpu_parts"].push_back(  // wall ms of the frame's parts (FrameRecord)
        {{"resize", f.resize_ms}, {"set_view", f.view_ms}, {"step", f.step_ms}, {"cache", f.cache_ms}, {"finish", f.finish_ms}});
    // The frame's occlusion sampling passes by route, its probe and the compared ms per pass
    // (the automatic route choice's inputs: docs/rendering.md, "Occlusion sampling pass").
    pf["sample_route"].push_back({{"raster", f.sample_raster},
                                  {"compute", f.sample_compute},
                                  {"probe", f.sample_probe < 0 ? "" : f.sample_probe == 1 ? "compute" : "raster"},
                                  {"probe_share", f.sample_probe_share},
                                  {"compared_ms", {{"raster", f.compared_raster_ms}, {"compute", f.compared_compute_ms}}}});
  }
  j["per_frame"] = pf;  // arrays: in the JSON only (the CSV keeps scalars)

  if (!o.json.empty()) MDS_TRY(write_text_atomically(o.json, j.dump(2) + "\n"));
  if (!o.csv.empty()) MDS_TRY(write_text_atomically(o.csv, stress::csv_summary(j)));
  if (!o.node_log.empty()) MDS_TRY(write_node_log(o.node_log, *reader, *renderer, vis));
  if (!o.trace.empty()) {
    // Belady's outcome per request, for comparing it with the online cache's request by request.
    std::vector<uint8_t> belady_hits;
    (void)streaming::simulate_belady(trace, sim_budget, false, &belady_hits);
    MDS_TRY(write_text_atomically(o.trace, stress::trace_csv(trace_frames, trace, trace_hits, belady_hits)));
  }

  // --- stdout table ---
  auto row = [](const std::string& k, const std::string& v) { std::printf("  %-34s %s\n", k.c_str(), v.c_str()); };
  std::printf("mdstream stress: %s, path %s (%u frames + %u settle + %u converged), policy %s, %ux%u\n",
              o.store.c_str(), path_name.c_str(), path_frames, settle_run, converged_run, streaming::policy_name(policy),
              o.width, o.height);
  row("GPU budget / pool / peak", fmt::format("{} / {} / {}", fmt_bytes(budget), fmt_bytes(c.pool_bytes), fmt_bytes(c.gpu_peak_bytes)));
  row("store payload", fmt::format("{} in {} nodes", fmt_bytes(reader->header().payload_bytes), nodes.size()));
  row("hit rate (online)", fmt::format("{} ({} hits, {} misses)", fmt_rate(hit_rate), c.cache_hits, c.cache_misses));
  row("hit rate Belady / bypass (offline)", fmt::format("{} / {}", fmt_rate(bounds.belady.hit_rate()), fmt_rate(bounds.belady_bypass.hit_rate())));
  row("hit rate LRU / FIFO (offline)", fmt::format("{} / {}", fmt_rate(bounds.lru.hit_rate()), fmt_rate(bounds.fifo.hit_rate())));
  row("bytes read / uploaded", fmt::format("{} ({:.2f}x store) / {}", fmt_bytes(c.bytes_read), j["bytes_read_over_store"].get<double>(), fmt_bytes(c.bytes_uploaded)));
  row("nodes loaded / never loaded / failed", fmt::format("{} / {} / {}", c.nodes_loaded, c.nodes_never_loaded, c.nodes_failed));
  if (!o.slices.empty() || !o.threshold.empty()) row("nodes left out (--slice, --threshold)", fmt::format("{}", c.nodes_left_out));
  row("evictions O / M / L / P", fmt::format("{} / {} / {} / {}", c.evictions[3], c.evictions[2], c.evictions[1], c.evictions[0]));
  row("upload stalls", fmt::format("{}", c.upload_stalls));
  row("late arrivals kept", fmt::format("{}", c.late_arrivals_kept));
  row("frame ms p50 / p99 / max (path)", fmt::format("{:.2f} / {:.2f} / {:.2f} (p99/p50 {:.2f})", q_path.p50, q_path.p99, q_path.max, q_path.ratio()));
  if (pacer)
    row("dynamic resolution", fmt::format("target {:.1f} ms{}, scale p50 {:.3f}, min {:.3f} (path)", pacer->target_ms(),
                                          o.pacing.frame_ms_target > 0.0 ? "" : " (auto)", j["scale_p50"].get<double>(),
                                          j["scale_min"].get<double>()));
  row("frame ms p50 / p99 (streaming)", fmt::format("{:.2f} / {:.2f} over {} frames", q_stream.p50, q_stream.p99, q_stream.n));
  if (!conv_wall.empty()) row("converged frame ms (wall / GPU)", fmt::format("{:.2f} / {:.2f}", stress::quantile(conv_wall, 0.5), stress::quantile(conv_gpu, 0.5)));
  row("views held / converged", fmt::format("{} / {}", views.size(), views_converged));
  for (const auto& v : views) {
    if (v.converged)
      row(fmt::format("view {} (frame {}, {} frames)", v.view, v.first_frame, v.frames),
          fmt::format("converged after {} frames, {:.1f} ms, {} read", v.frames_to_converge, v.ms_to_converge,
                      fmt_bytes(v.bytes_read_to_converge)));
    else
      row(fmt::format("view {} (frame {}, {} frames)", v.view, v.first_frame, v.frames), "not converged");
  }
  if (visible)
    row("final view: visible nodes / bytes",
        fmt::format("{} / {} (read to converge / visible: {})", visible->first, fmt_bytes(visible->second),
                    last.converged && visible->second
                        ? fmt::format("{:.2f}", double(last.bytes_read_to_converge) / double(visible->second))
                        : std::string("n/a")));
  for (const auto& e : c.errors) std::fprintf(stderr, "mdstream stress: %s\n", e.c_str());
  return {};
}

void setup_stress(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<StressOptions>();
  sub.add_option("store", opt->store, "Store file (.mds)")->required();
  add_stream_options(sub, opt->stream, true, false);
  add_pacing_options(sub, opt->pacing, false);
  sub.add_option("--path", opt->path,
                 "Camera path: orbit, flythrough, jumps (built-in), view0..view2 (a default view held), or a camera path file (docs/camera-path.md)")
      ->required();
  sub.add_option("--frames", opt->frames, "Frames of the path (0: 240 for built-ins, the file's frame count)")
      ->check(CLI::Range(0u, 10000000u))
      ->capture_default_str();
  sub.add_option("--settle-frames", opt->settle_frames,
                 "After the path, hold the final camera for at most this many frames until it has converged")
      ->check(CLI::Range(0u, 10000000u))
      ->capture_default_str();
  sub.add_option("--converged-frames", opt->converged_frames,
                 "Frames rendered after the final view converged (converged-frame cost)")
      ->check(CLI::Range(0u, 100000u))
      ->capture_default_str();
  sub.add_option("--known-path", opt->known_path,
                 "Tell the cache the path's next views: a moving view opens the read window from its first frame "
                 "and looks ahead along the path (false: the cache learns the motion from the views, as in the viewer)")
      ->capture_default_str();
  sub.add_option("--width", opt->width, "Image width")->check(CLI::Range(1u, 16384u))->capture_default_str();
  sub.add_option("--height", opt->height, "Image height")->check(CLI::Range(1u, 16384u))->capture_default_str();
  sub.add_option("--fov", opt->fov, "Vertical field of view of the built-in paths (degrees)")->capture_default_str();
  sub.add_option("--csv", opt->csv, "Write the summary as CSV (header + one row)");
  sub.add_option("--node-log", opt->node_log,
                 "Write one CSV row per node after the run: its class and what the cache did with it over the "
                 "whole path (read requests: a node read again after an eviction counts each time; the frame of "
                 "the first; loaded, resident, in the final view's frustum, wanted), and whether it holds a "
                 "visible particle of the converged final view (docs/streaming.md, \"Node log\")");
  sub.add_option("--trace", opt->trace,
                 "Write the demand trace the offline bounds replay as CSV (frame,node,bytes,hit,belady_hit: one row "
                 "per frame and wanted node; bytes = the node's pool bytes; hit = resident when the frame drew; "
                 "belady_hit = a hit of the offline Belady replay)");
  sub.add_option("--json", opt->json, "Write the full report (summary, views, offline bounds) as JSON");
  add_culling_options(sub, opt->cull, "No occlusion culling (every node in the frustum is wanted)");
  sub.add_option("--device", opt->device, "Vulkan device index (default: automatic, discrete GPU first)");
  sub.add_option("--slice", opt->slices,
                 "NX,NY,NZ,D[,WIDTH][,invert]: stream only the particles the slice keeps, as render --slice (nodes it "
                 "leaves out are never read); once per slice")
      ->allow_extra_args(false);
  sub.add_option("--threshold", opt->threshold,
                 "LO:HI[,invert]: stream only the particles whose property lies in [LO, HI], as render --threshold "
                 "(nodes whose property histogram holds no kept value are never read)");
  sub.add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
  sub.callback([opt, &exit_code] {
    Status st = run_stress(*opt);
    exit_code = st.ok() ? 0 : report("stress", st.error());
  });
}

Registrar reg("stress", "Cache stress test: replay a camera path through the streaming GPU cache", setup_stress);

}  // namespace
}  // namespace mds::cli
