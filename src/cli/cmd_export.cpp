// `mdstream export STORE|SERIES -o OUT [--slice SPEC ...] [--threshold LO:HI] [--series-frames SEL]`:
// decodes the nodes and writes their particles as extended XYZ (export_xyz.cpp), a LAMMPS dump
// (-o OUT.lammpstrj or .dump) or data file (-o OUT.data; export_lammps.cpp) or MMPLD (-o
// OUT.mmpld, export_mmpld.cpp).
// Positions are dequantized (x = center_min + q * step) and printed in shortest round-trip form,
// so the export adds no error to the store's quantization error. With slices (store/slice.h) and
// a threshold (store/threshold.h) only the particles they keep, the same ones `render --slice
// --threshold` draws; nodes the slices leave out, or whose property histogram holds no value the
// threshold keeps, are not read. A series (store/series.h) goes to one XYZ or dump file, a frame
// per picked store in order. The output appears only when complete.
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli/command.h"
#include "cli/export_nodes.h"
#include "core/frame_selection.h"
#include "store/file_io.h"
#include "store/series.h"
#include "store/store_reader.h"

namespace mds::cli {
namespace {

struct ExportOptions {
  std::string store;
  std::string output;
  std::vector<std::string> slices;  // --slice specs
  std::string threshold;            // --threshold spec
  std::string series_frames = "all";  // --series-frames of a .series STORE
};

enum class Format { xyz, lammps, lammps_data, mmpld };

Format format_of(const std::string& output) {
  std::string ext = std::filesystem::path(output).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".mmpld") return Format::mmpld;
  if (ext == ".lammpstrj" || ext == ".dump") return Format::lammps;
  if (ext == ".data") return Format::lammps_data;
  return Format::xyz;
}

// A store to export: its path, and its series time and index when it is a series frame.
struct Source {
  std::filesystem::path path;
  std::optional<double> time;
  int64_t index = 0;
  std::string label;  // "SERIES: frame K (NAME)" for messages; empty for one store
};

Result<std::vector<Source>> sources(const ExportOptions& o) {
  if (!store::is_series_path(o.store)) {
    if (o.series_frames != "all")
      return make_error(Errc::invalid_argument, "--series-frames {}: {} is one store, not a series", o.series_frames, o.store);
    return std::vector<Source>{{o.store, std::nullopt, 0, ""}};
  }
  MDS_ASSIGN_OR_RETURN(const store::Series series, store::read_series(o.store));
  auto sel = parse_frame_selection(o.series_frames);
  if (!sel.ok()) return make_error(Errc::invalid_argument, "--series-frames {}", sel.error().message);
  auto picked = select_frames(*sel, int64_t(series.frames.size()));
  if (!picked.ok()) return make_error(Errc::invalid_argument, "{}: --series-frames {}", o.store, picked.error().message);
  std::vector<Source> v;
  for (const int64_t k : *picked) {
    const store::SeriesFrame& f = series.frames[size_t(k)];
    v.push_back({f.path, f.time, k, fmt::format("{}: frame {} ({})", o.store, k, f.name)});
  }
  return v;
}

Error in_frame(const Source& s, Error e) {
  if (!s.label.empty()) e.message = s.label + ": " + e.message;
  return e;
}

// XYZ and LAMMPS dumps: every picked store a frame of one file. A store whose particles the
// filter all leaves out is an error; in a series such a frame is written empty, and the error
// comes only when every frame is.
Status export_text(const ExportOptions& o, Format format) {
  MDS_ASSIGN_OR_RETURN(const std::vector<Source> src, sources(o));
  if (format == Format::lammps_data && src.size() != 1)
    return make_error(Errc::invalid_argument,
                      "{}: a LAMMPS data file holds one frame: pick one with --series-frames K (or export the series "
                      "to .lammpstrj)",
                      o.store);
  // LAMMPS files: one type numbering over every picked store, and one timestep rule.
  std::optional<LammpsTypes> types;
  bool time_is_step = true;
  if (format != Format::xyz) {
    std::vector<std::vector<store::TypeEntry>> tables;
    std::set<double> times;
    for (const Source& s : src) {
      auto reader = store::StoreReader::open(s.path);
      if (!reader.ok()) return in_frame(s, reader.error());
      tables.emplace_back((*reader)->types().begin(), (*reader)->types().end());
      if (s.time) {
        const double t = *s.time;
        time_is_step = time_is_step && t == std::floor(t) && t >= 0.0 && t < 9.0e18 && times.insert(t).second;
      }
    }
    types = lammps_types(tables);
  }
  std::optional<store::AtomicOutput> out;
  std::optional<store::BufferedWriter> w;
  uint64_t total = 0;
  std::optional<Error> nothing;
  for (const Source& s : src) {
    auto frame = [&]() -> Status {
      MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(s.path));
      MDS_ASSIGN_OR_RETURN(const ExportFilter filter, ExportFilter::make(o.slices, o.threshold, *reader));
      MDS_ASSIGN_OR_RETURN(const uint64_t count, kept_count(*reader, filter));
      if (count == 0 && filter.any()) {
        if (src.size() == 1) return filter.nothing_kept(*reader);
        if (!nothing) nothing = filter.nothing_kept(*reader);
      }
      total += count;
      if (!out) {  // the file is made once the first frame is known to be writable
        MDS_ASSIGN_OR_RETURN(auto created, store::AtomicOutput::create(o.output));
        out.emplace(std::move(created));
        w.emplace(out->file(), size_t(8) << 20);
      }
      const ExportFrame f{*reader, filter, count, s.time, s.index, time_is_step, types ? &*types : nullptr};
      return format == Format::lammps        ? write_lammps_frame(f, *w)
             : format == Format::lammps_data ? write_lammps_data(f, *w)
                                             : write_xyz_frame(f, *w);
    };
    if (Status st = frame(); !st.ok()) return in_frame(s, st.error());
  }
  if (total == 0 && nothing)
    return make_error(Errc::invalid_argument, "{}: in every picked frame: {}", o.store, nothing->message);
  MDS_TRY(w->flush());
  return out->commit();
}

Status export_mmpld_file(const ExportOptions& o) {
  MDS_ASSIGN_OR_RETURN(const std::vector<Source> src, sources(o));
  if (src.size() != 1)
    return make_error(Errc::invalid_argument,
                      "{}: an MMPLD export holds one frame: pick one with --series-frames K (or export the series to "
                      ".xyz or .lammpstrj)",
                      o.store);
  MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(src[0].path));
  MDS_ASSIGN_OR_RETURN(const ExportFilter filter, ExportFilter::make(o.slices, o.threshold, *reader));
  if (Status st = export_mmpld(*reader, filter, o.output); !st.ok()) return in_frame(src[0], st.error());
  return {};
}

void setup_export(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<ExportOptions>();
  sub.add_option("store", opt->store, "Store file (.mds), or a series index (.series: one frame per picked store)")
      ->required();
  sub.add_option("-o,--output", opt->output,
                 "Output file: extended XYZ; a LAMMPS dump (id type x y z, radius, property, element) when it ends "
                 "in .lammpstrj or .dump; a LAMMPS data file (read_data: atomic, or sphere with per-particle radii) "
                 "when it ends in .data; MMPLD 1.0 for MegaMol when it ends in .mmpld (one list per type, the "
                 "store's colours, property or type colours)")
      ->required();
  sub.add_option("--slice", opt->slices,
                 "NX,NY,NZ,D[,WIDTH][,invert]: only the particles the slice keeps, as render --slice (docs/rendering.md, "
                 "\"Slices\"); once per slice, all applied")
      ->allow_extra_args(false);
  sub.add_option("--threshold", opt->threshold,
                 "LO:HI[,invert]: only the particles whose per-particle property lies in [LO, HI] (an empty LO or HI: "
                 "open; invert: the others), as render --threshold (docs/rendering.md, \"Thresholds\")");
  sub.add_option("--series-frames", opt->series_frames,
                 "Frames of a series to export, in order, as the frames of one XYZ or dump file: all, last, K, or a "
                 "slice A:B[:S] (as render --series-frames)")
      ->capture_default_str();
  sub.callback([opt, &exit_code] {
    const Format f = format_of(opt->output);
    Status st = f == Format::mmpld ? export_mmpld_file(*opt) : export_text(*opt, f);
    exit_code = st.ok() ? 0 : report("export", st.error());
  });
}

Registrar reg("export", "Decode a store (.mds) or a series to extended XYZ, a LAMMPS dump or MMPLD", setup_export);

}  // namespace
}  // namespace mds::cli
