// Trajectory -> store series; see series_convert.h.
#include "convert/series_convert.h"

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

// The frames to convert, in series order, with their steps.
Result<std::vector<Planned>> plan_frames(const ConvertOptions& o, const std::optional<FrameSelection>& frames) {
  std::vector<Planned> plan;
  if (o.inputs.size() == 1) {
    MDS_ASSIGN_OR_RETURN(std::vector<FrameEntry> list, list_frames(o.inputs[0], o.reader));
    MDS_ASSIGN_OR_RETURN(FrameSelection sel, frames ? Result<FrameSelection>(*frames) : parse_frame_selection("all"));
    auto picked = select_frames(sel, int64_t(list.size()));
    if (!picked.ok())
      return make_error(Errc::invalid_argument, "{}: --frames {}", o.inputs[0].string(), picked.error().message);
    for (int64_t k : *picked) plan.push_back({o.inputs[0], k, list[size_t(k)].timestep, list[size_t(k)].mark});
    return plan;
  }
  if (frames)
    return make_error(Errc::invalid_argument, "--frames {}: picks frames of one input; with {} inputs each input is "
                      "one frame of the series (--frame picks it)", frames->text, o.inputs.size());
  for (const auto& in : o.inputs) {
    MDS_ASSIGN_OR_RETURN(std::unique_ptr<ParticleReader> r, open_reader(in, o.reader));
    plan.push_back({in, o.reader.frame, r->info().timestep, FrameMark{}});
  }
  std::set<int64_t> steps;
  for (const Planned& p : plan) steps.insert(p.timestep);
  if (steps.size() == plan.size()) {
    std::stable_sort(plan.begin(), plan.end(), [](const Planned& a, const Planned& b) { return a.timestep < b.timestep; });
  }
  return plan;
}

}  // namespace

Result<SeriesReport> convert_series(const ConvertOptions& o, const std::optional<FrameSelection>& frames,
                                    const SeriesProgressFn& on_frame) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!store::is_series_path(o.output))
    return make_error(Errc::invalid_argument, "{}: a series index must end in .series (RUN.mds.series)",
                      o.output.string());
  if (o.inputs.empty()) return make_error(Errc::invalid_argument, "no input files given");
  MDS_ASSIGN_OR_RETURN(std::vector<Planned> plan, plan_frames(o, frames));
  std::set<int64_t> steps;
  for (const Planned& p : plan) steps.insert(p.timestep);
  const bool distinct_steps = steps.size() == plan.size();

  SeriesReport rep;
  std::vector<std::filesystem::path> written;
  const auto undo = [&](Error e) {
    std::error_code ec;
    for (const auto& p : written) std::filesystem::remove(p, ec);
    return e;
  };
  // One input: its text source passes from frame to frame (a compressed file is read once).
  const auto relay = o.inputs.size() == 1 ? std::make_shared<TextSourceRelay>() : nullptr;
  for (size_t k = 0; k < plan.size(); ++k) {
    ConvertOptions fo = o;
    fo.reader.relay = relay;
    fo.inputs = {plan[k].input};
    fo.reader.frame = plan[k].input_frame;
    fo.reader.start = plan[k].mark;
    fo.output = series_store_path(o.output, k, plan.size());
    auto r = convert(fo);
    if (!r.ok()) {
      Error e = r.error();
      e.message = fmt::format("series frame {} of {} ({} frame {}): {}", k, plan.size(), plan[k].input.string(),
                              plan[k].input_frame, e.message);
      return undo(std::move(e));
    }
    written.push_back(fo.output);
    store::SeriesFrame sf;
    sf.name = fo.output.filename().string();
    sf.path = fo.output;
    sf.time = distinct_steps ? double(plan[k].timestep) : double(k);
    rep.frames.push_back(sf);
    rep.reports.push_back({plan[k].input_frame, plan[k].timestep, std::move(*r)});
    if (on_frame) on_frame(k, plan.size(), rep.reports.back());
  }
  if (Status st = store::write_series(o.output, rep.frames); !st.ok()) return undo(st.error());
  rep.seconds_total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

}  // namespace mds::convert
