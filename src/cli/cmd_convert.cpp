// `mdstream convert INPUT... -o OUT.mds [options]`: simulation dumps -> node/meshlet store;
// `-o RUN.mds.series [--frames SEL]`: a trajectory -> one store per frame and their index.
// The pipeline lives in preprocess/convert/converter.{h,cpp} (series_convert.h for series);
// this file parses options, prints the summary and writes the optional JSON report.
#include <cstdio>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/cell_text.h"
#include "cli/command.h"
#include "core/byte_size.h"
#include "convert/converter.h"
#include "convert/series_convert.h"
#include "core/frame_selection.h"
#include "core/text_file.h"
#include "readers/replicate_reader.h"
#include "store/format.h"
#include "store/series.h"

namespace mds::cli {

namespace {

struct ConvertArgs {
  std::vector<std::string> inputs;
  std::string output;
  std::string format = "auto";
  std::string frame = "0";
  bool frame_given = false;
  std::string frames;  // --frames: a series of the one input's frames
  std::string h5md_group;
  std::string property;
  bool color = false;
  bool wrap = false;
  std::string replicate;
  uint32_t node_size = 10000;
  uint32_t meshlet_size = 16;
  std::string meshlet_builder = "pcl";
  float radius = 0.5f;
  std::string radius_by_type;
  std::string density_res;
  std::string memory_budget = "2GiB";
  unsigned threads = 2;
  std::string tmp_dir;
  bool quiet = false;
  std::string json_report;
};

nlohmann::json report_json(const convert::ConvertReport& r, const convert::ConvertOptions& o) {
  nlohmann::json j;
  std::vector<std::string> inputs;
  for (const auto& p : o.inputs) inputs.push_back(p.string());
  j["inputs"] = inputs;
  j["output"] = o.output.string();
  j["particles"] = r.particles;
  j["nodes"] = r.nodes;
  j["meshlets"] = r.meshlets;
  j["types"] = r.types;
  j["mean_meshlet_size"] = r.mean_meshlet_size;
  j["meshlet_builder"] = convert::meshlet_builder_name(r.meshlet_builder);
  j["meshlet_quality"] = {{"mean_size", r.mean_meshlet_size}, {"diag_over_spacing", r.meshlet_diag_over_spacing}};
  j["file_bytes"] = r.file_bytes;
  j["bytes_per_particle"] = r.bytes_per_particle;
  j["payload_bytes"] = r.payload_bytes;
  j["payload_raw_bytes"] = r.payload_raw_bytes;
  j["compression_ratio"] = r.compression_ratio;
  j["max_quantization_error"] = r.max_quantization_error;
  j["max_error_over_half_step"] = r.max_error_over_half_step;
  j["bounds_min"] = {r.bounds_min[0], r.bounds_min[1], r.bounds_min[2]};
  j["bounds_max"] = {r.bounds_max[0], r.bounds_max[1], r.bounds_max[2]};
  j["density_dims"] = {r.density_dims[0], r.density_dims[1], r.density_dims[2]};
  j["per_particle_radius"] = r.per_particle_radius;
  j["color"] = r.color;
  j["wrapped"] = o.reader.wrap;
  j["replicated"] = o.reader.replicate;
  j["cell"] = r.cell ? cell_json(*r.cell) : nlohmann::json(nullptr);
  if (!r.property.empty()) j["property"] = {{"name", r.property}, {"min", r.property_min}, {"max", r.property_max}};
  j["spilled"] = r.spilled;
  j["bins"] = r.bins;
  j["partition_passes"] = r.partition_passes;
  j["memory_budget"] = r.memory_budget;
  j["peak_rss_bytes"] = r.peak_rss_bytes;
  j["threads"] = o.threads;
  j["node_size"] = o.node_size;
  j["meshlet_size"] = o.meshlet_size;
  j["seconds"] = {{"read", r.seconds_read},         {"partition", r.seconds_partition},
                  {"build", r.seconds_build},       {"sort", r.seconds_sort},
                  {"gather_cpu", r.seconds_gather}, {"meshlets_cpu", r.seconds_meshlets},
                  {"encode_cpu", r.seconds_encode}, {"append_cpu", r.seconds_append},
                  {"finish", r.seconds_finish},     {"total", r.seconds_total},
                  {"cpu", r.cpu_seconds},           {"setup", r.seconds_setup},
                  {"load", r.seconds_load},         {"keys", r.seconds_keys},
                  {"radix", r.seconds_radix},       {"nodes", r.seconds_nodes}};
  // Contiguous stages of the conversion (wall seconds add up to seconds.total), with the process
  // CPU seconds (all threads) spent while each ran.
  nlohmann::json stages = nlohmann::json::array();
  for (const auto& st : r.stages) stages.push_back({{"name", st.name}, {"wall", st.wall}, {"cpu", st.cpu}});
  j["stages"] = stages;
  j["particles_per_second"] = r.particles_per_second;
  return j;
}

void print_summary(const convert::ConvertReport& r, const convert::ConvertOptions& o) {
  std::fprintf(stderr,
               "wrote %s\n"
               "  particles        %llu (%u types%s)\n"
               "  nodes            %llu (max %u particles)\n"
               "  meshlets         %llu (%s builder, mean %.2f particles, max %u; bbox diagonal %.2f x spacing)\n"
               "  file             %llu bytes, %.3f bytes/particle\n"
               "  compression      %.3f (payload raw %llu -> %llu bytes)\n"
               "  max quant. error %.6g (%.4f of half a step)\n"
               "  density grid     %ux%ux%u\n"
               "  memory           budget %.1f MiB, peak RSS %.1f MiB, %s, %llu bins\n"
               "  time             %.2f s total (read %.2f, partition %.2f, build %.2f of which sort %.2f), "
               "%.2f M particles/s, CPU %.2f s\n"
               "  build CPU        gather %.2f s, meshlets %.2f s, encode %.2f s, append %.2f s\n",
               o.output.string().c_str(), static_cast<unsigned long long>(r.particles), r.types,
               r.per_particle_radius ? ", per-particle radius" : "", static_cast<unsigned long long>(r.nodes),
               o.node_size, static_cast<unsigned long long>(r.meshlets), convert::meshlet_builder_name(r.meshlet_builder),
               r.mean_meshlet_size, o.meshlet_size, r.meshlet_diag_over_spacing,
               static_cast<unsigned long long>(r.file_bytes), r.bytes_per_particle, r.compression_ratio,
               static_cast<unsigned long long>(r.payload_raw_bytes), static_cast<unsigned long long>(r.payload_bytes),
               r.max_quantization_error, r.max_error_over_half_step, r.density_dims[0], r.density_dims[1],
               r.density_dims[2], double(r.memory_budget) / (1 << 20), double(r.peak_rss_bytes) / (1 << 20),
               r.spilled ? "spilled to temporary files" : "in memory", static_cast<unsigned long long>(r.bins),
               r.seconds_total, r.seconds_read, r.seconds_partition, r.seconds_build, r.seconds_sort,
               r.particles_per_second / 1e6, r.cpu_seconds, r.seconds_gather, r.seconds_meshlets, r.seconds_encode,
               r.seconds_append);
  if (r.color) std::fprintf(stderr, "  colours          RGBA8 per particle\n");
  const auto& rep = o.reader.replicate;
  if (rep != std::array<uint32_t, 3>{1, 1, 1})
    std::fprintf(stderr, "  replicated       %ux%ux%u images of each input particle\n", rep[0], rep[1], rep[2]);
  if (r.cell) std::fprintf(stderr, "  cell             %s\n", cell_line(*r.cell).c_str());
  else if (r.cells_differ) std::fprintf(stderr, "  cell             none kept: the inputs' cells differ\n");
  if (!r.property.empty())
    std::fprintf(stderr, "  property         %s in [%.6g, %.6g], 16 bits (step %.3g)\n", r.property.c_str(),
                 double(r.property_min), double(r.property_max),
                 (double(r.property_max) - double(r.property_min)) / store::kQuantMax);
}

Result<convert::ConvertOptions> to_options(const ConvertArgs& a) {
  convert::ConvertOptions o;
  for (const auto& s : a.inputs) o.inputs.emplace_back(s);
  o.output = a.output;
  auto fmt = parse_input_format(a.format);
  if (!fmt) return make_error(Errc::invalid_argument, "--format '{}': expected auto, lammps, xyz, h5md, mmpld or raw", a.format);
  o.reader.format = *fmt;
  if (a.frame == "last") {
    o.reader.frame = -1;
  } else {
    try {
      size_t used = 0;
      const long long k = std::stoll(a.frame, &used);
      if (used != a.frame.size() || k < 0) throw std::invalid_argument("frame");
      o.reader.frame = k;
    } catch (const std::exception&) {
      return make_error(Errc::invalid_argument, "--frame '{}': expected a frame index >= 0 or 'last'", a.frame);
    }
  }
  o.reader.h5md_group = a.h5md_group;
  o.reader.property = a.property;
  o.reader.color = a.color;
  o.reader.wrap = a.wrap;
  if (!a.replicate.empty()) {
    MDS_ASSIGN_OR_RETURN(o.reader.replicate, parse_replicate_counts(a.replicate));
  }
  o.node_size = a.node_size;
  o.meshlet_size = a.meshlet_size;
  auto mb = convert::parse_meshlet_builder(a.meshlet_builder);
  if (!mb) return make_error(Errc::invalid_argument, "--meshlet-builder '{}': expected pcl or octree", a.meshlet_builder);
  o.meshlet_builder = *mb;
  o.radius = a.radius;
  if (!a.radius_by_type.empty()) {
    MDS_ASSIGN_OR_RETURN(o.radius_by_type, convert::parse_radius_by_type(a.radius_by_type));
  }
  if (!a.density_res.empty()) {
    MDS_ASSIGN_OR_RETURN(o.density, convert::parse_density_res(a.density_res));
  }
  MDS_ASSIGN_OR_RETURN(o.memory_budget, parse_byte_size(a.memory_budget));
  o.threads = a.threads;
  o.tmp_dir = a.tmp_dir;
  o.progress = !a.quiet && stderr_is_tty();
  return o;
}

Status write_json_report(const std::string& file, const nlohmann::json& j) {
  return write_text_atomically(file, j.dump(2) + "\n");
}

int run_series(const ConvertArgs& args, const convert::ConvertOptions& opts) {
  std::optional<FrameSelection> frames;
  if (!args.frames.empty()) {
    auto sel = parse_frame_selection(args.frames);
    if (!sel.ok()) return report("convert", make_error(Errc::invalid_argument, "--frames {}", sel.error().message));
    frames = *sel;
  }
  if (opts.inputs.size() == 1 && args.frame_given)
    return report("convert", make_error(Errc::invalid_argument, "--frame {} with a series output: pick the input's "
                                        "frames with --frames", args.frame));
  auto rep = convert::convert_series(opts, frames, [&](size_t k, size_t n, const convert::SeriesFrameReport& f) {
    if (!args.quiet)
      std::fprintf(stderr, "frame %zu/%zu: %s frame %lld (step %lld): %llu particles, %.2f s -> %s\n", k + 1, n,
                   opts.inputs.size() == 1 ? opts.inputs[0].string().c_str() : "input", (long long)f.input_frame,
                   (long long)f.timestep, (unsigned long long)f.report.particles, f.report.seconds_total,
                   convert::series_store_path(opts.output, k, n).filename().string().c_str());
  });
  if (!rep.ok()) return report("convert", rep.error());
  if (!args.json_report.empty()) {
    nlohmann::json j;
    j["series"] = opts.output.string();
    j["seconds_total"] = rep->seconds_total;
    nlohmann::json frames_json = nlohmann::json::array();
    for (size_t k = 0; k < rep->frames.size(); ++k) {
      convert::ConvertOptions fo = opts;
      fo.output = rep->frames[k].path;
      nlohmann::json fj = report_json(rep->reports[k].report, fo);
      fj["input_frame"] = rep->reports[k].input_frame;
      fj["timestep"] = rep->reports[k].timestep;
      fj["time"] = rep->frames[k].time;
      frames_json.push_back(std::move(fj));
    }
    j["frames"] = std::move(frames_json);
    if (Status st = write_json_report(args.json_report, j); !st.ok()) return report("convert", st.error());
  }
  if (!args.quiet) {
    uint64_t particles = 0, bytes = 0;
    for (const auto& f : rep->reports) {
      particles += f.report.particles;
      bytes += f.report.file_bytes;
    }
    std::fprintf(stderr, "wrote %s: %zu frames, %llu particles, %llu bytes of stores, %.2f s (%.2f M particles/s)\n",
                 opts.output.string().c_str(), rep->frames.size(), (unsigned long long)particles,
                 (unsigned long long)bytes, rep->seconds_total,
                 rep->seconds_total > 0 ? double(particles) / rep->seconds_total / 1e6 : 0.0);
  }
  return 0;
}

int run_convert(const ConvertArgs& args) {
  auto opts = to_options(args);
  if (!opts.ok()) return report("convert", opts.error());
  if (store::is_series_path(opts->output)) return run_series(args, *opts);
  if (!args.frames.empty())
    return report("convert", make_error(Errc::invalid_argument, "--frames {}: writes a series of stores; name its "
                                        "index RUN.mds.series with -o (got {})", args.frames, args.output));
  auto rep = convert::convert(*opts);
  if (!rep.ok()) return report("convert", rep.error());
  if (!args.json_report.empty()) {
    if (Status st = write_json_report(args.json_report, report_json(*rep, *opts)); !st.ok())
      return report("convert", st.error());
  }
  if (!args.quiet) print_summary(*rep, *opts);
  return 0;
}

void setup_convert(CLI::App& sub, int& exit_code) {
  auto args = std::make_shared<ConvertArgs>();
  sub.add_option("inputs", args->inputs,
                 "Input files (LAMMPS dump, XYZ/extended XYZ, H5MD, MMPLD, raw float32 xyz); several files are "
                 "concatenated into one particle set, types merged by input id")
      ->required();
  sub.add_option("-o,--output", args->output,
                 "Output store (.mds), or a series index (.series, see --frames); written to a temporary file, renamed "
                 "when complete")
      ->required();
  sub.add_option("--format", args->format, "Input format: auto|lammps|xyz|h5md|mmpld|raw (raw must be explicit)")
      ->capture_default_str();
  CLI::Option* frame_opt =
      sub.add_option("--frame", args->frame, "Frame to convert: index K (0 = first) or 'last'")->capture_default_str();
  sub.add_option("--h5md-group", args->h5md_group, "H5MD particle group under /particles when there are several");
  sub.add_option("--property", args->property,
                 "Keep one per-particle scalar for colour coding (render --color-by property): a LAMMPS column such as "
                 "c_pe or vx, an extended-XYZ R:1 property, the H5MD dataset /particles/<group>/NAME/value, or MMPLD's "
                 "'intensity'; stored as 16 bits over its range");
  sub.add_flag("--color", args->color,
               "Keep per-particle colours (RGBA, 8 bits a channel; render draws them): MMPLD's colours (UINT8/FLOAT/USHORT "
               "RGB(A), or a list's global colour) or extended XYZ's color:R:3 (OVITO's Color, channels in [0, 1])");
  sub.add_flag("--wrap", args->wrap,
               "Wrap the positions into the periodic simulation cell (along its periodic vectors, as OVITO's Wrap at "
               "periodic boundaries; unwrapped coordinates such as LAMMPS' xu yu zu come out as LAMMPS wraps them); "
               "an input without a periodic cell is an error");
  sub.add_option("--replicate", args->replicate,
                 "Periodic images: NA,NB,NC (or NAxNBxNC) copies along the cell vectors a, b, c, as LAMMPS' replicate "
                 "and OVITO's Replicate; the cell grows to NA a, NB b, NC c (after --wrap); an input without a cell is "
                 "an error");
  sub.add_option("--node-size", args->node_size, "Maximum particles per node (1..65535)")->capture_default_str();
  sub.add_option("--meshlet-size", args->meshlet_size, "Particles per meshlet (1..255)")->capture_default_str();
  sub.add_option("--meshlet-builder", args->meshlet_builder,
                 "Meshlet builder: pcl (octree leaves filled to the meshlet size from PCL kd-tree neighbourhoods) or "
                 "octree (the leaves of the implicit octree "
                 "over Morton keys: much faster, smaller meshlets; compare the quality in the summary)")
      ->capture_default_str();
  sub.add_option("--radius", args->radius, "Radius of every type without its own (--radius-by-type, MMPLD list radius)")
      ->capture_default_str();
  sub.add_option("--radius-by-type", args->radius_by_type, "Per-type radius, e.g. 1=0.5,2=0.7");
  sub.add_option("--density-res", args->density_res,
                 "Density volume: a target voxel count N (voxels close to cubic) or explicit dims AxBxC. Default: about "
                 "1M voxels (1048576), but at most one voxel per 8 particles for small inputs");
  sub.add_option("--memory-budget", args->memory_budget,
                 "Peak working memory, e.g. 512MiB, 2GiB, 1.5G; inputs larger than this are partitioned through "
                 "temporary files")
      ->capture_default_str();
  sub.add_option("--threads", args->threads, "Threads for the raw input's scan and sort, the Morton keys and radix sort, and the per-node work "
                 "(meshlets, quantization, encoding); text is parsed on the hardware threads (at most 8)")->capture_default_str();
  sub.add_option("--tmp-dir", args->tmp_dir, "Directory for temporary files (default: the output's directory)");
  sub.add_flag("-q,--quiet", args->quiet, "Print nothing but errors");
  sub.add_option("--json-report", args->json_report, "Also write the conversion report as JSON to this file");
  sub.add_option("--frames", args->frames,
                 "Convert a trajectory to a series of stores: -o RUN.mds.series writes RUN.0000.mds, RUN.0001.mds, ... "
                 "and the index (ParaView's .series JSON). SEL picks the input's frames: all (the default with a "
                 ".series output), last, K, or a slice A:B[:S] (B exclusive, negative from the end). With several "
                 "inputs each one is a frame, ordered by its timestep");
  sub.callback([args, &exit_code, frame_opt] {
    args->frame_given = frame_opt->count() > 0;
    exit_code = run_convert(*args);
  });
}

Registrar reg("convert", "Convert simulation dumps (LAMMPS, XYZ, H5MD, MMPLD, raw) to an mdstream store", setup_convert);

}  // namespace

}  // namespace mds::cli
