// Trajectory -> store series; see series_convert.h.
#include "convert/series_convert.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <set>

namespace mds::convert {

std::filesystem::path series_store_path(const std::filesystem::path& series, size_t k, size_t n) {
  std::string stem = series.filename().string();
  for (const char* ext : {".series", ".mds"})
    if (stem.size() > std::strlen(ext) && stem.ends_with(ext)) stem.resize(stem.size() - std::strlen(ext));
  const int width = std::max<int>(4, int(fmt::format("{}", n > 0 ? n - 1 : 0).size()));
  return series.parent_path() / fmt::format("{}.{:0{}}.mds", stem, k, width);
}

namespace {

struct Planned {
  std::filesystem::path input;
  int64_t input_frame = 0;
  int64_t timestep = 0;
  FrameMark mark;
};

struct Plan {
  std::vector<Planned> frames;  // in series order
  bool distinct_steps = true;   // every frame declares its own step: the times are the steps
};

// The frames to convert, in series order, with their steps.
Result<Plan> plan_frames(const ConvertOptions& o, const std::optional<FrameSelection>& frames) {
  Plan out;
  std::vector<Planned>& plan = out.frames;
  if (o.inputs.size() == 1) {
    MDS_ASSIGN_OR_RETURN(std::vector<FrameEntry> list, list_frames(o.inputs[0], o.reader));
    MDS_ASSIGN_OR_RETURN(FrameSelection sel, frames ? Result<FrameSelection>(*frames) : parse_frame_selection("all"));
    auto picked = select_frames(sel, int64_t(list.size()));
    if (!picked.ok())
      return make_error(Errc::invalid_argument, "{}: --frames {}", o.inputs[0].string(), picked.error().message);
    for (int64_t k : *picked) plan.push_back({o.inputs[0], k, list[size_t(k)].timestep, list[size_t(k)].mark});
  } else {
    if (frames)
      return make_error(Errc::invalid_argument, "--frames {}: picks frames of one input; with {} inputs each input "
                        "is one frame of the series (--frame picks it)", frames->text, o.inputs.size());
    for (const auto& in : o.inputs) {
      MDS_ASSIGN_OR_RETURN(std::unique_ptr<ParticleReader> r, open_reader(in, o.reader));
      plan.push_back({in, o.reader.frame, r->info().timestep, FrameMark{}});
    }
  }
  std::set<int64_t> steps;
  for (const Planned& p : plan) steps.insert(p.timestep);
  out.distinct_steps = steps.size() == plan.size();
  if (o.inputs.size() > 1 && out.distinct_steps)
    std::stable_sort(plan.begin(), plan.end(), [](const Planned& a, const Planned& b) { return a.timestep < b.timestep; });
  return out;
}

// True when `a` and `b` name the same file (or would).
bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ea, eb;
  const auto ca = std::filesystem::weakly_canonical(a, ea), cb = std::filesystem::weakly_canonical(b, eb);
  return !ea && !eb && ca == cb;
}

}  // namespace

Result<SeriesReport> convert_series(const ConvertOptions& o, const std::optional<FrameSelection>& frames,
                                    const SeriesProgressFn& on_frame) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!store::is_series_path(o.output))
    return make_error(Errc::invalid_argument, "{}: a series index must end in .series (RUN.mds.series)",
                      o.output.string());
  if (o.inputs.empty()) return make_error(Errc::invalid_argument, "no input files given");
  MDS_ASSIGN_OR_RETURN(const Plan planned, plan_frames(o, frames));
  const std::vector<Planned>& plan = planned.frames;
  for (size_t k = 0; k < plan.size(); ++k)
    for (const auto& in : o.inputs)
      if (same_file(series_store_path(o.output, k, plan.size()), in))
        return make_error(Errc::invalid_argument, "{}: the series' store {} would overwrite an input", o.output.string(),
                          series_store_path(o.output, k, plan.size()).string());

  // Each store is written under a temporary name and renamed over its final one only once every
  // frame converted: a failed run leaves the stores and the index of an earlier run as they were.
  SeriesReport rep;
  std::vector<std::filesystem::path> pending;
  const auto undo = [&](Error e) {
    std::error_code ec;
    for (const auto& p : pending) std::filesystem::remove(p, ec);
    return e;
  };
  const std::string tmp_suffix = fmt::format(".new.{}", ::getpid());
  // One input: its text source passes from frame to frame (a compressed file is read once).
  const auto relay = o.inputs.size() == 1 ? std::make_shared<TextSourceRelay>() : nullptr;
  for (size_t k = 0; k < plan.size(); ++k) {
    const std::filesystem::path final_path = series_store_path(o.output, k, plan.size());
    ConvertOptions fo = o;
    fo.reader.relay = relay;
    fo.inputs = {plan[k].input};
    fo.reader.frame = plan[k].input_frame;
    fo.reader.start = plan[k].mark;
    fo.output = final_path.string() + tmp_suffix;
    auto r = convert(fo);
    if (!r.ok()) {
      Error e = r.error();
      e.message = fmt::format("series frame {} of {} ({} frame {}): {}", k, plan.size(), plan[k].input.string(),
                              plan[k].input_frame, e.message);
      return undo(std::move(e));
    }
    pending.push_back(fo.output);
    store::SeriesFrame sf;
    sf.name = final_path.filename().string();
    sf.path = final_path;
    sf.time = planned.distinct_steps ? double(plan[k].timestep) : double(k);
    rep.frames.push_back(sf);
    rep.reports.push_back({plan[k].input_frame, plan[k].timestep, std::move(*r)});
    if (on_frame) on_frame(k, plan.size(), rep.reports.back());
  }
  // Every frame converted: the stores into place (renames within one folder), then the index.
  for (size_t k = 0; k < pending.size(); ++k) {
    std::error_code ec;
    std::filesystem::rename(pending[k], rep.frames[k].path, ec);
    if (ec)
      return undo(make_error(Errc::io, "{}: cannot rename {} to it: {}", rep.frames[k].path.string(),
                             pending[k].string(), ec.message()));
  }
  if (Status st = store::write_series(o.output, rep.frames); !st.ok()) return st.error();
  rep.seconds_total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

}  // namespace mds::convert
