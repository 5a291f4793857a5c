#include "cli/vulkan/stream_options.h"

#include <fmt/format.h>

#include "core/byte_size.h"

namespace mds::cli {

void add_stream_options(CLI::App& sub, StreamOptions& o, bool budget_required, bool series) {
  auto* b = sub.add_option("--gpu-budget", o.gpu_budget,
                           std::string("Stream node payloads through a GPU cache of this size (e.g. 512MiB, 2GiB)") +
                               (budget_required ? "" : "; default: the whole store in memory"));
  if (budget_required) b->required();
  sub.add_option("--policy", o.policy, "Cache policy: occlusion, lru or fifo (docs/streaming.md)")->capture_default_str();
  sub.add_option("--io-threads", o.io_threads, "Background reader threads")->check(CLI::Range(1u, 64u))->capture_default_str();
  sub.add_option("--io-latency-ms", o.io_latency_ms, "Simulated latency per node read (a slow disk), ms")
      ->check(CLI::Range(0.0, 60000.0))
      ->capture_default_str();
  sub.add_option("--io-bandwidth", o.io_bandwidth, "Simulated read bandwidth per reader, bytes/s (e.g. 200MB); default unlimited");
  sub.add_option("--upload-per-frame,--upload-budget", o.upload_per_frame, "Bytes uploaded to the GPU per frame at most")
      ->capture_default_str();
  sub.add_option("--max-outstanding", o.max_outstanding,
                 "Cap of the node reads queued or in flight at a time (the window adapts from --wave-nodes per held view, 4 without waves)")
      ->check(CLI::Range(1u, 100000u))
      ->capture_default_str();
  sub.add_option("--moving-waste-share", o.moving_waste_share,
                 "While the camera moves, the read window halves only after a frame in which at least this share "
                 "of the arrived reads were for nodes found occluded meanwhile (0: any such read; docs/streaming.md)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub.add_option("--wave-settle-frames", o.wave_settle_frames,
                 "At rest, reads go out in waves: the next wave waits until the last one's nodes have been resident "
                 "this many frames (sampled as occluders); 0: no waves (docs/streaming.md)")
      ->check(CLI::Range(0u, 1000u))
      ->capture_default_str();
  sub.add_option("--wave-nodes", o.wave_nodes,
                 "Nodes of the first wave at rest and the window's step (at most --max-outstanding; unused without "
                 "waves; docs/streaming.md, \"Wave size\")")
      ->check(CLI::Range(1u, 100000u))
      ->capture_default_str();
  sub.add_option("--wave-coverage", o.wave_coverage,
                 "A wave at rest also reads, front to back, nodes until their bounding spheres cover this many "
                 "images (at least --wave-nodes, at most --max-outstanding); 0: --wave-nodes and the window alone "
                 "(docs/streaming.md, \"Wave coverage\")")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  sub.add_option("--front-node-alone", o.front_node_alone,
                 "At rest, a wave whose first node is large on screen and dense reads it alone (true/false; "
                 "docs/streaming.md, \"Wave size\")")
      ->capture_default_str();
  sub.add_option("--keep-late-arrivals", o.keep_late_arrivals,
                 "A read that arrives for a node found occluded meanwhile is kept in room that nodes evicted before "
                 "it can free, instead of dropped (true/false; docs/streaming.md, \"Late arrivals\")")
      ->capture_default_str();
  sub.add_option("--occluded-hold-frames", o.occluded_hold_frames,
                 "While the camera moves, a node found occluded stays unread until no culling iteration has "
                 "confirmed it for this many frames (docs/streaming.md, \"Camera changes\")")
      ->check(CLI::Range(0u, 1000000u))
      ->capture_default_str();
  if (!series) return;
  sub.add_option("--series-first-wave", o.series_first_wave,
                 "A series step (or a cache made again): prior = the first wave reads, all at once, the nodes "
                 "whose boxes match those the view before wanted; cold = an empty cache's waves "
                 "(docs/streaming.md, \"Series steps\")")
      ->check(CLI::IsMember({"prior", "cold"}))
      ->capture_default_str();
}

Result<render::StreamSettings> stream_settings(const StreamOptions& o) {
  render::StreamSettings ss;
  auto named = [](const char* option, const Error& e) { return make_error(Errc::invalid_argument, "{}: {}", option, e.message); };
  auto budget = parse_byte_size(o.gpu_budget);
  if (!budget.ok()) return named("--gpu-budget", budget.error());
  ss.gpu_budget = *budget;
  MDS_ASSIGN_OR_RETURN(ss.policy, mds::streaming::parse_policy(o.policy));
  auto upload = parse_byte_size(o.upload_per_frame);
  if (!upload.ok()) return named("--upload-per-frame", upload.error());
  ss.upload_bytes_per_frame = *upload;
  if (!o.io_bandwidth.empty()) {
    auto bw = parse_byte_size(o.io_bandwidth);
    if (!bw.ok()) return named("--io-bandwidth", bw.error());
    ss.io.io_bandwidth = double(*bw);
  }
  if (!(o.io_latency_ms >= 0.0 && o.io_latency_ms < 1e6))
    return make_error(Errc::invalid_argument, "--io-latency-ms {}: expected a number of milliseconds >= 0", o.io_latency_ms);
  ss.io.threads = o.io_threads;
  ss.io.io_latency_ms = o.io_latency_ms;
  ss.max_outstanding = o.max_outstanding;
  ss.moving_waste_share = o.moving_waste_share;
  ss.wave_settle_frames = o.wave_settle_frames;
  ss.wave_nodes = o.wave_nodes;
  ss.wave_coverage = o.wave_coverage;
  ss.front_node_alone = o.front_node_alone;
  ss.keep_late_arrivals = o.keep_late_arrivals;
  ss.occluded_hold_frames = o.occluded_hold_frames;
  ss.carry_view = o.series_first_wave == "prior";
  return ss;
}

void add_pacing_options(CLI::App& sub, PacingOptions& o, bool default_on) {
  o.dynamic = default_on;
  sub.add_flag("--dynamic-resolution,!--fixed-resolution", o.dynamic,
               std::string("While the camera moves, render at a reduced resolution picked from recent frame times "
                           "against --frame-ms-target; full resolution when it rests (default: ") +
                   (default_on ? "on" : "off") + ")");
  sub.add_option("--frame-ms-target", o.frame_ms_target,
                 "Frame time target of the dynamic resolution, ms (0: 1.25x the median full-resolution moving frame)")
      ->capture_default_str();
  sub.add_option("--min-scale", o.min_scale, "Smallest render scale (of width and height) of the dynamic resolution")
      ->capture_default_str();
  sub.add_option("--pace-arrivals", o.watch_arrivals,
                 "Dynamic resolution: a frame that lacked more wanted nodes than it drew (nodes on their way) "
                 "raises no scale (docs/viewer.md)")
      ->capture_default_str();
  sub.add_option("--pace-samples", o.scale_samples,
                 "Dynamic resolution: a moving frame's occlusion sampling pass selects the render size's share of "
                 "the pixels of the occluder budget, at least 1/16 (false: the whole budget at every scale; "
                 "docs/viewer.md)")
      ->capture_default_str();
  sub.add_option("--pace-gpu-time", o.pace_gpu_time,
                 "Dynamic resolution: only the frame's GPU time scales with the render size, the rest of it "
                 "(CPU work) is fixed; auto: on a GPU, not on a CPU device such as lavapipe (false: the whole "
                 "frame scales; docs/viewer.md)")
      ->check(CLI::IsMember({"auto", "true", "false"}))
      ->capture_default_str();
}

Result<render::PacerSettings> pacer_settings(const PacingOptions& o) {
  if (!(o.frame_ms_target >= 0.0 && o.frame_ms_target < 1e7))
    return make_error(Errc::invalid_argument, "--frame-ms-target {}: expected milliseconds >= 0 (0: automatic)",
                      o.frame_ms_target);
  if (!(o.min_scale > 0.0 && o.min_scale <= 1.0))
    return make_error(Errc::invalid_argument, "--min-scale {}: expected a fraction in (0, 1]", o.min_scale);
  render::PacerSettings p;
  p.target_ms = o.frame_ms_target;
  p.min_scale = o.min_scale;
  p.watch_arrivals = o.watch_arrivals;
  p.scale_samples = o.scale_samples;
  p.gpu_split = o.pace_gpu_time == "true"    ? render::GpuSplit::on
                : o.pace_gpu_time == "false" ? render::GpuSplit::off
                                             : render::GpuSplit::gpu_devices;
  return p;
}

std::vector<std::string> cache_warnings(const render::CacheStats& c, uint64_t max_storage_range) {
  std::vector<std::string> out;
  if (!c.enabled) return out;
  if (c.pool_device_capped)
    out.push_back(fmt::format("the pool is {} of the {} of --gpu-budget: this device's maxStorageBufferRange ({}) "
                              "bounds the pool's buffers "
                              "(docs/streaming.md, \"Limits\")",
                              format_bytes(c.pool_bytes), format_bytes(c.gpu_budget_bytes),
                              format_bytes(max_storage_range)));
  if (c.budget_exhausted)
    out.push_back(fmt::format(
        "the image is incomplete: the view wants {} nodes ({} of pool pages: in the frustum and not known to be "
        "occluded), more than the pool of {} holds; {}",
        c.wanted_nodes, format_bytes(c.wanted_bytes), format_bytes(c.pool_bytes),
        c.pool_device_capped ? "this device holds no larger pool: choose a closer view, or convert with a smaller "
                               "--node-size (fewer hidden particles per node read)"
                             : fmt::format("a --gpu-budget of {} would hold them all (less may do: the nodes "
                                           "read first may occlude others)",
                                           format_bytes(c.wanted_bytes))));
  return out;
}

}  // namespace mds::cli
