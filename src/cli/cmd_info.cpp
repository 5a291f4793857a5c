// `mdstream info STORE [--json] [--verify] [--histogram N]`: summary of a store (header, types,
// sizes, quantization), as text or JSON. --verify also reads and decodes every node payload and
// checks that its occupancy record holds its particles and its property histogram is its own.
// --histogram N counts the property's values in N bins (store/property_distribution.h). For a
// series index (store/series.h): one line per frame (time, counts, bounds) and the totals;
// --verify checks every store.
#include <algorithm>
#include <bit>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/cell_text.h"
#include "cli/command.h"
#include "store/series.h"
#include "store/property_distribution.h"
#include "store/store_reader.h"
#include "store/type_style.h"

namespace mds::cli {
namespace {

struct InfoOptions {
  std::string store;
  bool json = false;
  bool verify = false;
  uint32_t histogram = 0;  // --histogram N: bins of the property's distribution (0: none)
};

// --histogram: the distribution of the property (store/property_distribution.h) as JSON.
Result<nlohmann::json> histogram_json(const store::StoreReader& r, uint32_t bins) {
  MDS_ASSIGN_OR_RETURN(const store::PropertyDistribution d, store::property_distribution(r, bins));
  return nlohmann::json{{"name", std::string(r.header().property_name)}, {"bins", bins}, {"edges", d.edges},
                        {"counts", d.counts}, {"nodes_read", d.nodes_read}};
}

// The histogram as text: one row per bin, its range, count and a bar (40 characters at the
// largest count).
std::string histogram_text(const nlohmann::json& hj, uint64_t nodes) {
  const auto counts = hj["counts"].get<std::vector<uint64_t>>();
  const auto edges = hj["edges"].get<std::vector<double>>();
  const uint64_t top = counts.empty() ? 0 : *std::max_element(counts.begin(), counts.end());
  std::string s = fmt::format("histogram        {}, {} bins ({} of {} nodes read; the others counted from their "
                              "property histograms)\n",
                              hj["name"].get<std::string>(), counts.size(), hj["nodes_read"].get<uint64_t>(), nodes);
  for (size_t b = 0; b < counts.size(); ++b) {
    const size_t bar = top ? size_t(std::llround(40.0 * double(counts[b]) / double(top))) : 0;
    s += fmt::format("  [{:>11.6g}, {:>11.6g}{} {:>12} {}\n", edges[b], edges[b + 1], b + 1 == counts.size() ? "]" : ")",
                     counts[b], std::string(bar, '#'));
  }
  return s;
}

nlohmann::json vec3(const double v[3]) { return nlohmann::json::array({v[0], v[1], v[2]}); }

Result<nlohmann::json> store_info(const store::StoreReader& r) {
  const store::FileHeader& h = r.header();
  nlohmann::json j;
  j["file"] = r.path().string();
  j["format_version"] = h.version;
  j["file_bytes"] = r.file_bytes();
  j["particles"] = h.particle_count;
  j["nodes"] = h.node_count;
  j["meshlets"] = h.meshlet_count;
  j["node_size_max"] = h.node_size_max;
  j["meshlet_size_max"] = h.meshlet_size_max;
  j["per_particle_radius"] = (h.flags & store::kFlagPerParticleRadius) != 0;
  j["radius_min"] = h.radius_min;
  j["radius_max"] = h.radius_max;
  if (h.flags & store::kFlagProperty)
    j["property"] = {{"name", std::string(h.property_name)}, {"min", h.property_min}, {"max", h.property_max},
                     {"node_histograms", (h.flags & store::kFlagPropertyHistogram) != 0}};
  else
    j["property"] = nullptr;
  j["color"] = (h.flags & store::kFlagColor) != 0;
  j["cell"] = r.cell() ? cell_json(*r.cell()) : nlohmann::json(nullptr);
  j["bounds_min"] = vec3(h.bounds_min);
  j["bounds_max"] = vec3(h.bounds_max);
  j["max_quantization_error"] = h.max_quantization_error;
  j["max_error_over_half_step"] = h.max_error_over_half_step;
  // Quantization step of a node = its largest axis step; report max and median over nodes.
  std::vector<double> steps;
  steps.reserve(r.nodes().size());
  for (const auto& e : r.nodes())
    steps.push_back(std::max({store::quant_step(e, 0), store::quant_step(e, 1), store::quant_step(e, 2)}));
  double step_max = 0, step_median = 0;
  if (!steps.empty()) {
    step_max = *std::max_element(steps.begin(), steps.end());
    auto mid = steps.begin() + steps.size() / 2;
    std::nth_element(steps.begin(), mid, steps.end());
    step_median = *mid;
  }
  j["quantization_step"] = {{"max", step_max}, {"median", step_median}};
  j["density_dims"] = {h.density_dims[0], h.density_dims[1], h.density_dims[2]};
  j["density_min"] = vec3(h.density_min);
  j["density_max"] = vec3(h.density_max);
  j["bytes_per_particle"] = h.particle_count ? double(r.file_bytes()) / double(h.particle_count) : 0.0;
  j["payload_bytes"] = h.payload_bytes;
  j["payload_raw_bytes"] = h.payload_raw_bytes;
  j["compression_ratio"] = h.payload_bytes ? double(h.payload_raw_bytes) / double(h.payload_bytes) : 0.0;
  // Occupancy records (docs/store-format.md "Occupancy"): the share of the 512 cells set, mean
  // over nodes, and the nodes with every cell set (which the culling tests by their box alone).
  uint64_t set = 0, full = 0;
  for (uint32_t i = 0; i < h.node_count; ++i) {
    uint64_t node_set = 0;
    for (uint8_t b : r.occupancy(i)) node_set += uint64_t(std::popcount(b));
    set += node_set;
    full += node_set == 8 * store::kOccupancyBytes;
  }
  j["occupancy"] = {{"cells_set_fraction", h.node_count ? double(set) / (8.0 * store::kOccupancyBytes * h.node_count) : 0.0},
                    {"full_nodes", full}};
  nlohmann::json types = nlohmann::json::array();
  const auto ts = r.types();
  for (size_t i = 0; i < ts.size(); ++i)
    types.push_back({{"index", i},
                     {"id", ts[i].input_id},
                     {"name", std::string(ts[i].name)},
                     {"radius", ts[i].radius},
                     {"count", ts[i].particle_count},
                     {"color", store::srgb_hex(store::default_type_color(uint32_t(i)))}});  // render's default
  j["types"] = types;
  return j;
}

Status verify_payloads(const store::StoreReader& r) {
  store::NodeData node;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < r.nodes().size(); ++i) {
    MDS_TRY(r.read_node(i, node, scratch));
    MDS_TRY(r.verify_occupancy(i, node));
    MDS_TRY(r.verify_property_histogram(i, node));
  }
  return {};
}

// "(x, y, z)" of a JSON array of three numbers.
std::string v3(const nlohmann::json& a) {
  return fmt::format("({:.6g}, {:.6g}, {:.6g})", a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
}

std::string human(const nlohmann::json& j, const std::optional<SimulationCell>& cell, bool verified) {
  std::string s;
  s += fmt::format("store            {}\n", j["file"].get<std::string>());
  s += fmt::format("format version   {}\n", j["format_version"].get<uint32_t>());
  s += fmt::format("file size        {} bytes ({:.3f} bytes/particle)\n", j["file_bytes"].get<uint64_t>(),
                   j["bytes_per_particle"].get<double>());
  s += fmt::format("particles        {}\n", j["particles"].get<uint64_t>());
  s += fmt::format("nodes            {} (at most {} particles)\n", j["nodes"].get<uint64_t>(),
                   j["node_size_max"].get<uint32_t>());
  s += fmt::format("meshlets         {} (at most {} particles)\n", j["meshlets"].get<uint64_t>(),
                   j["meshlet_size_max"].get<uint32_t>());
  s += fmt::format("bounds           {} .. {}\n", v3(j["bounds_min"]), v3(j["bounds_max"]));
  if (cell) s += fmt::format("cell             {}\n", cell_line(*cell));
  s += fmt::format("radius           {}, range [{:.6g}, {:.6g}]\n",
                   j["per_particle_radius"].get<bool>() ? "per particle" : "per type", j["radius_min"].get<double>(),
                   j["radius_max"].get<double>());
  if (j["color"].get<bool>()) s += "colours          RGBA8 per particle\n";
  if (!j["property"].is_null())
    s += fmt::format("property         {} in [{:.6g}, {:.6g}], 16 bits{}\n", j["property"]["name"].get<std::string>(),
                     j["property"]["min"].get<double>(), j["property"]["max"].get<double>(),
                     j["property"]["node_histograms"].get<bool>() ? "; a histogram per node" : "");
  s += fmt::format("quantization     16 bit; step max {:.6g}, median {:.6g}; max error {:.6g} ({:.4f} of half a step)\n",
                   j["quantization_step"]["max"].get<double>(), j["quantization_step"]["median"].get<double>(),
                   j["max_quantization_error"].get<double>(), j["max_error_over_half_step"].get<double>());
  s += fmt::format("density grid     {}x{}x{} over {} .. {}\n", j["density_dims"][0].get<uint32_t>(),
                   j["density_dims"][1].get<uint32_t>(), j["density_dims"][2].get<uint32_t>(), v3(j["density_min"]),
                   v3(j["density_max"]));
  s += fmt::format("payloads         {} bytes LZ4 from {} bytes (ratio {:.3f})\n", j["payload_bytes"].get<uint64_t>(),
                   j["payload_raw_bytes"].get<uint64_t>(), j["compression_ratio"].get<double>());
  s += fmt::format("occupancy        {:.1f} % of the 8^3 cells per node set (mean); {} nodes full\n",
                   100.0 * j["occupancy"]["cells_set_fraction"].get<double>(), j["occupancy"]["full_nodes"].get<uint64_t>());
  s += fmt::format("types            {}\n", j["types"].size());
  for (const auto& t : j["types"])
    s += fmt::format("  [{}] id {:<6} name {:<10} radius {:<8.4g} colour {} particles {}\n", t["index"].get<size_t>(),
                     t["id"].get<int32_t>(), t["name"].get<std::string>().empty() ? "-" : t["name"].get<std::string>(),
                     t["radius"].get<double>(), t["color"].get<std::string>(), t["count"].get<uint64_t>());
  if (verified) s += "verify           every node payload read, hash-checked and decoded, occupancy and property histograms checked: ok\n";
  return s;
}

// Every store of a series opened (and verified), the series' JSON; the first error names the frame.
Result<nlohmann::json> series_info(const std::string& file, bool verify) {
  MDS_ASSIGN_OR_RETURN(const store::Series series, store::read_series(file));
  nlohmann::json frames = nlohmann::json::array();
  uint64_t particles = 0, bytes = 0;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (size_t k = 0; k < series.frames.size(); ++k) {
    const store::SeriesFrame& f = series.frames[k];
    auto r = store::StoreReader::open(f.path);
    Status st = r.ok() && verify ? verify_payloads(**r) : Status{};
    if (!r.ok() || !st.ok()) {
      Error e = r.ok() ? st.error() : r.error();
      e.message = fmt::format("{}: frame {} ({}): {}", file, k, f.name, e.message);
      return e;
    }
    const store::FileHeader& h = (*r)->header();
    for (int d = 0; d < 3; ++d) {
      lo[d] = k == 0 ? h.bounds_min[d] : std::min(lo[d], h.bounds_min[d]);
      hi[d] = k == 0 ? h.bounds_max[d] : std::max(hi[d], h.bounds_max[d]);
    }
    particles += h.particle_count;
    bytes += (*r)->file_bytes();
    frames.push_back({{"name", f.name},
                      {"time", f.time},
                      {"particles", h.particle_count},
                      {"nodes", h.node_count},
                      {"file_bytes", (*r)->file_bytes()},
                      {"bounds_min", vec3(h.bounds_min)},
                      {"bounds_max", vec3(h.bounds_max)},
                      {"cell", (*r)->cell() ? cell_json(*(*r)->cell()) : nlohmann::json(nullptr)}});
  }
  nlohmann::json j;
  j["series"] = file;
  j["frame_count"] = series.frames.size();
  j["particles_total"] = particles;
  j["file_bytes_total"] = bytes;
  j["bounds_min"] = vec3(lo);  // over every frame
  j["bounds_max"] = vec3(hi);
  j["frames"] = std::move(frames);
  return j;
}

std::string series_human(const nlohmann::json& j, bool verified) {
  std::string s;
  s += fmt::format("series           {}\n", j["series"].get<std::string>());
  s += fmt::format("frames           {}\n", j["frame_count"].get<size_t>());
  s += fmt::format("particles        {} in all frames\n", j["particles_total"].get<uint64_t>());
  s += fmt::format("stores           {} bytes\n", j["file_bytes_total"].get<uint64_t>());
  s += fmt::format("bounds           {} .. {} (all frames)\n", v3(j["bounds_min"]), v3(j["bounds_max"]));
  s += fmt::format("  {:>5}  {:>12}  {:>12}  {:>7}  {:<24} {}\n", "frame", "time", "particles", "nodes", "store",
                   "bounds");
  size_t k = 0;
  for (const auto& f : j["frames"])
    s += fmt::format("  {:>5}  {:>12.10g}  {:>12}  {:>7}  {:<24} {} .. {}\n", k++, f["time"].get<double>(),
                     f["particles"].get<uint64_t>(), f["nodes"].get<uint64_t>(), f["name"].get<std::string>(),
                     v3(f["bounds_min"]), v3(f["bounds_max"]));
  if (verified) s += "verify           every store's node payloads read, hash-checked and decoded: ok\n";
  return s;
}

void setup_info(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<InfoOptions>();
  sub.add_option("store", opt->store, "Store file (.mds) or series index (.series)")->required();
  sub.add_flag("--json", opt->json, "Print JSON instead of text");
  sub.add_flag("--verify", opt->verify,
               "Also read, hash-check and decode every node payload and check its occupancy record and property histogram");
  sub.add_option("--histogram", opt->histogram,
                 "Also count the store's per-particle property (convert --property) in N equal bins over its range, "
                 "as ParaView's Histogram: to choose a --threshold (nodes whose values fall into one bin are counted "
                 "from their property histograms, the others read)")
      ->check(CLI::Range(1u, 10000u));
  sub.callback([opt, &exit_code] {
    if (store::is_series_path(opt->store) && opt->histogram) {
      exit_code = report("info", make_error(Errc::invalid_argument, "--histogram takes one store, not the series {}",
                                            opt->store));
      return;
    }
    if (store::is_series_path(opt->store)) {
      auto j = series_info(opt->store, opt->verify);
      if (!j.ok()) {
        exit_code = report("info", j.error());
        return;
      }
      if (opt->verify) (*j)["verified"] = true;
      std::fputs(opt->json ? (j->dump(2) + "\n").c_str() : series_human(*j, opt->verify).c_str(), stdout);
      exit_code = 0;
      return;
    }
    auto reader = store::StoreReader::open(opt->store);
    if (!reader.ok()) {
      exit_code = report("info", reader.error());
      return;
    }
    if (opt->verify) {
      Status st = verify_payloads(**reader);
      if (!st.ok()) {
        exit_code = report("info", st.error());
        return;
      }
    }
    auto j = store_info(**reader);
    if (!j.ok()) {
      exit_code = report("info", j.error());
      return;
    }
    if (opt->histogram) {
      auto hj = histogram_json(**reader, opt->histogram);
      if (!hj.ok()) {
        exit_code = report("info", make_error(hj.error().code, "--histogram: {}", hj.error().message));
        return;
      }
      (*j)["property_histogram"] = std::move(*hj);
    }
    if (opt->json) {
      if (opt->verify) (*j)["verified"] = true;
      std::fputs((j->dump(2) + "\n").c_str(), stdout);
    } else {
      std::string text = human(*j, (*reader)->cell(), opt->verify);
      if (j->contains("property_histogram")) text += histogram_text((*j)["property_histogram"], (*reader)->nodes().size());
      std::fputs(text.c_str(), stdout);
    }
    exit_code = 0;
  });
}

Registrar reg("info", "Summarize a store (.mds) or a store series (.series): counts, bounds, quantization, types, sizes",
              setup_info);

}  // namespace
}  // namespace mds::cli
