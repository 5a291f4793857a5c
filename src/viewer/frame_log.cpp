#include "viewer/frame_log.h"

#include <unistd.h>

#include <string>
#include <system_error>

namespace mds::viewer {

Result<std::unique_ptr<FrameLog>> FrameLog::open(const std::filesystem::path& path) {
  std::unique_ptr<FrameLog> log(new FrameLog());
  log->path_ = path;
  log->tmp_ = path.string() + ".tmp." + std::to_string(::getpid());
  log->f_ = std::fopen(log->tmp_.c_str(), "w");
  if (!log->f_) return make_error(Errc::io, "--frame-log {}: cannot open for writing", log->tmp_.string());
  std::fprintf(log->f_,
               "frame,t_ms,frame_ms,step_ms,gpu_ms,stepped,camera_moved,samples,converged,culling_active,complete,"
               "nodes_uploaded,bytes_uploaded,frame_hits,frame_misses,upload_stall,resident_bytes,in_flight,"
               "bytes_read,P,L,M,O,scale,render_width,render_height,series_frame,reload_ms,held\n");
  return log;
}

FrameLog::~FrameLog() {
  if (f_) {
    std::fclose(f_);
    std::error_code ec;
    std::filesystem::remove(tmp_, ec);  // not committed: no partial output
  }
}

void FrameLog::add(const FrameLogRow& r) {
  const auto& p = r.report;
  std::fprintf(f_, "%u,%.3f,%.3f,%.3f,%.3f,%d,%d,%u,%d,%d,%d,%u,%llu,%u,%u,%d,%llu,%llu,%llu,%u,%u,%u,%u,%.4f,%u,%u,%lld,%.3f,%d\n", r.frame,
               r.t_ms, r.frame_ms, r.step_ms, p.gpu_ms, int(r.stepped), int(r.camera_moved), p.samples,
               int(p.converged), int(p.culling_active), int(p.complete), p.nodes_uploaded,
               (unsigned long long)p.bytes_uploaded, p.frame_hits, p.frame_misses, int(p.upload_stall),
               (unsigned long long)r.cache.resident_bytes, (unsigned long long)r.cache.in_flight,
               (unsigned long long)r.cache.bytes_read, p.class_counts[0], p.class_counts[1], p.class_counts[2],
               p.class_counts[3], r.scale, r.render_width, r.render_height,
               (long long)r.series_frame, r.reload_ms, int(r.held));
}

Status FrameLog::commit() {
  const bool ok = std::fflush(f_) == 0 && !std::ferror(f_);
  std::fclose(f_);
  f_ = nullptr;
  std::error_code ec;
  if (!ok) {
    std::filesystem::remove(tmp_, ec);
    return make_error(Errc::io, "--frame-log {}: write failed", tmp_.string());
  }
  std::filesystem::rename(tmp_, path_, ec);
  if (ec) {
    std::filesystem::remove(tmp_, ec);
    return make_error(Errc::io, "--frame-log {}: cannot rename into place", path_.string());
  }
  return {};
}

}  // namespace mds::viewer
