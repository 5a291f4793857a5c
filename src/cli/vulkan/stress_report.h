// Report logic of `mdstream stress` (issue 4): frame-time quantiles, per-view convergence
// (a view is a run of frames with the same camera), and the offline bound: the request trace
// recorded from FrameReport::wanted replayed through the Belady/MIN simulation (Belady 1966,
// streaming/belady.h) and LRU/FIFO with the same byte budget. Header-only so that the unit
// tests (tests/test_stress_cli.cpp) check the same code the CLI runs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "streaming/belady.h"

namespace mds::cli::stress {

// What the stress loop keeps of each frame (FrameReport plus the cumulative bytes read).
struct FrameRecord {
  uint32_t view = 0;        // index of the run of frames with the same camera
  bool settle = false;      // after the path: the final camera held until converged
  bool after_converged = false;  // extra frames after the final view converged (converged-frame cost)
  double wall_ms = 0.0;
  double gpu_ms = 0.0;                          // this frame's timestamped passes
  // CPU wall time of the frame's parts: resize (all before set_view: --dynamic-resolution's
  // scale and Renderer::resize, the motion and path hints), set_view (a new camera: the cache's view, the culling reset), step (of
  // it: the cache's update), finish (waits for the frame's GPU work).
  double resize_ms = 0.0, view_ms = 0.0, step_ms = 0.0, cache_ms = 0.0, finish_ms = 0.0;
  std::map<std::string, double> gpu_passes;     // per pass (the sampling passes of an iteration summed)
  // The frame's occlusion sampling passes by route, its probe (-1 none, 0 raster, 1 compute) and
  // the probe's budget divisor, and the routes' compared ms per pass (FrameReport::sample_*).
  uint32_t sample_raster = 0, sample_compute = 0;
  int sample_probe = -1;
  uint32_t sample_probe_share = 0;
  double compared_raster_ms = -1.0, compared_compute_ms = -1.0;
  bool converged = false;
  bool complete = false;
  bool upload_stall = false;
  uint32_t hits = 0, misses = 0;
  uint32_t reads_requested = 0;       // node reads submitted by this frame's prefetch
  uint32_t upload_regions = 0;        // copy regions of the frame's pool transfers (after merging)
  uint64_t bytes_uploaded = 0;
  uint64_t bytes_read_total = 0;      // cumulative compressed bytes read after this frame
  uint32_t wanted_nodes = 0;
  uint64_t wanted_payload_bytes = 0;  // compressed store bytes of this frame's wanted nodes
  double scale = 1.0;                 // --dynamic-resolution: render scale of this frame
};

// Linear-interpolated quantiles (numpy's default), p in [0, 1].
inline double quantile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = p * double(v.size() - 1);
  const size_t lo = size_t(std::floor(pos)), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (pos - double(lo));
}

struct Quantiles {
  size_t n = 0;
  double p50 = 0.0, p99 = 0.0, max = 0.0;
  double ratio() const { return p50 > 0.0 ? p99 / p50 : 0.0; }
};

inline Quantiles quantiles(const std::vector<double>& v) {
  Quantiles q;
  q.n = v.size();
  if (v.empty()) return q;
  q.p50 = quantile(v, 0.5);
  q.p99 = quantile(v, 0.99);
  q.max = *std::max_element(v.begin(), v.end());
  return q;
}

struct ViewResult {
  uint32_t view = 0;
  uint32_t first_frame = 0;
  uint32_t frames = 0;          // frames of the view (path and settle frames, not after_converged)
  uint32_t settle_frames = 0;   // of those, held after the path
  bool converged = false;
  uint32_t frames_to_converge = 0;  // from the view's first frame to the first converged one, inclusive
  double ms_to_converge = 0.0;      // sum of wall_ms over those frames
  uint64_t bytes_read_to_converge = 0;
  uint32_t wanted_nodes_at_convergence = 0;
  uint64_t wanted_bytes_at_convergence = 0;  // compressed bytes of the nodes not in O in the view
};

// One ViewResult per run of frames with the same view index, in order. Runs of a single frame
// are camera motion, not held views: they are left out unless keep_single_frame_views, except the
// last view (the held final camera).
inline std::vector<ViewResult> summarize_views(const std::vector<FrameRecord>& frames,
                                               bool keep_single_frame_views = false) {
  std::vector<ViewResult> out;
  uint64_t read_before = 0;
  size_t i = 0;
  while (i < frames.size()) {
    size_t j = i;
    ViewResult v;
    v.view = frames[i].view;
    v.first_frame = uint32_t(i);
    double ms = 0.0;
    for (; j < frames.size() && frames[j].view == frames[i].view; ++j) {
      const FrameRecord& f = frames[j];
      if (f.after_converged) continue;
      ++v.frames;
      v.settle_frames += f.settle;
      if (v.converged) continue;
      ms += f.wall_ms;
      if (f.converged) {
        v.converged = true;
        v.frames_to_converge = uint32_t(j - i + 1);
        v.ms_to_converge = ms;
        v.bytes_read_to_converge = f.bytes_read_total - read_before;
        v.wanted_nodes_at_convergence = f.wanted_nodes;
        v.wanted_bytes_at_convergence = f.wanted_payload_bytes;
      }
    }
    const bool last = j == frames.size();
    if (v.frames >= 2 || last || keep_single_frame_views) out.push_back(v);
    read_before = frames[j - 1].bytes_read_total;
    i = j;
  }
  return out;
}

struct SimBounds {
  uint64_t budget_bytes = 0;
  streaming::CacheSimResult belady, belady_bypass, lru, fifo;
};

inline SimBounds simulate_bounds(const std::vector<streaming::TraceRequest>& trace, uint64_t budget) {
  SimBounds b;
  b.budget_bytes = budget;
  b.belady = streaming::simulate_belady(trace, budget, false);
  b.belady_bypass = streaming::simulate_belady(trace, budget, true);
  b.lru = streaming::simulate_lru(trace, budget);
  b.fifo = streaming::simulate_fifo(trace, budget);
  return b;
}

inline nlohmann::ordered_json sim_json(const streaming::CacheSimResult& r) {
  return {{"requests", r.requests},         {"hits", r.hits},
          {"hit_rate", r.hit_rate()},       {"bytes_requested", r.bytes_requested},
          {"bytes_hit", r.bytes_hit},       {"byte_hit_rate", r.byte_hit_rate()},
          {"evictions", r.evictions}};
}

inline nlohmann::ordered_json quantiles_json(const Quantiles& q) {
  return {{"frames", q.n}, {"p50", q.p50}, {"p99", q.p99}, {"max", q.max}, {"p99_over_p50", q.ratio()}};
}

inline nlohmann::ordered_json view_json(const ViewResult& v) {
  nlohmann::ordered_json j = {{"view", v.view},
                      {"first_frame", v.first_frame},
                      {"frames", v.frames},
                      {"settle_frames", v.settle_frames},
                      {"converged", v.converged}};
  if (v.converged) {
    j["frames_to_converge"] = v.frames_to_converge;
    j["ms_to_converge"] = v.ms_to_converge;
    j["bytes_read_to_converge"] = v.bytes_read_to_converge;
    j["wanted_nodes_at_convergence"] = v.wanted_nodes_at_convergence;
    j["wanted_bytes_at_convergence"] = v.wanted_bytes_at_convergence;
  } else {
    j["frames_to_converge"] = nullptr;
    j["ms_to_converge"] = nullptr;
  }
  return j;
}

// The flat one-row summary of the --csv output: the JSON report's scalar fields, nested objects
// flattened with '_' ("evictions_O", "frame_ms_p99", "belady_hit_rate"), arrays left out.
inline void flatten(const nlohmann::ordered_json& j, const std::string& prefix, std::vector<std::string>& keys,
                    std::vector<std::string>& values) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = prefix.empty() ? it.key() : prefix + "_" + it.key();
    const auto& v = it.value();
    if (v.is_object()) {
      flatten(v, key, keys, values);
    } else if (v.is_array()) {
      continue;
    } else {
      keys.push_back(key);
      if (v.is_string()) {
        std::string s = v.get<std::string>();
        if (s.find_first_of(",\"\n") != std::string::npos) {
          std::string q = "\"";
          for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
          s = q + "\"";
        }
        values.push_back(s);
      } else if (v.is_null()) {
        values.push_back("");
      } else if (v.is_number_float()) {
        values.push_back(fmt::format("{}", v.get<double>()));
      } else {
        values.push_back(v.dump());
      }
    }
  }
}

inline std::string csv_summary(const nlohmann::ordered_json& report) {
  std::vector<std::string> keys, values;
  flatten(report, "", keys, values);
  std::string out;
  for (size_t i = 0; i < keys.size(); ++i) out += (i ? "," : "") + keys[i];
  out += "\n";
  for (size_t i = 0; i < values.size(); ++i) out += (i ? "," : "") + values[i];
  out += "\n";
  return out;
}

// The demand trace (`stress --trace`): one row per frame and wanted node, in request order,
// with the online cache's outcome (hit: resident when the frame drew) and that of the offline
// Belady replay (simulate_belady's hit_out). Precondition: frames, hits and belady_hits have
// trace.size() entries (the frame and the outcomes of each request; missing outcomes read 0).
inline std::string trace_csv(const std::vector<uint32_t>& frames, const std::vector<streaming::TraceRequest>& trace,
                             const std::vector<uint8_t>& hits, const std::vector<uint8_t>& belady_hits) {
  std::string out = "frame,node,bytes,hit,belady_hit\n";
  for (size_t i = 0; i < trace.size() && i < frames.size(); ++i)
    out += fmt::format("{},{},{},{},{}\n", frames[i], trace[i].node, trace[i].bytes, i < hits.size() ? hits[i] : 0,
                       i < belady_hits.size() ? belady_hits[i] : 0);
  return out;
}

}  // namespace mds::cli::stress
