// `mdstream export STORE -o OUT.xyz`: decodes every node and writes extended XYZ
// (species, dequantized positions x = center_min + q * step, and the per-particle radius
// when the store has one). Numbers are printed in shortest round-trip form, so the export
// adds no error to the store's quantization error. The output appears only when complete.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli/command.h"
#include "store/file_io.h"
#include "store/store_reader.h"

namespace mds::cli {
namespace {

struct ExportOptions {
  std::string store;
  std::string output;
};

Status export_xyz(const ExportOptions& o) {
  MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(o.store));
  const store::FileHeader& h = reader->header();
  const bool radius = (h.flags & store::kFlagPerParticleRadius) != 0;
  const bool property = (h.flags & store::kFlagProperty) != 0;
  std::string property_name = property ? std::string(h.property_name) : "";
  for (char& c : property_name)  // a token of the Properties triples (an H5MD element may hold these)
    if (c == ':' || c == '=' || c == '"' || c == ' ' || c == '\t') c = '_';
  const std::string property_column = property ? fmt::format(":{}:R:1", property_name) : "";
  std::vector<std::string> species;
  for (const auto& t : reader->types()) {
    std::string name = t.name[0] ? std::string(t.name) : std::to_string(t.input_id);
    for (char& c : name)
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r') c = '_';  // one token per column
    species.push_back(std::move(name));
  }

  MDS_ASSIGN_OR_RETURN(auto out, store::AtomicOutput::create(o.output));
  store::BufferedWriter w(out.file(), size_t(8) << 20);
  fmt::memory_buffer buf;
  fmt::format_to(std::back_inserter(buf), "{}\nProperties=species:S:1:pos:R:3{}{} mdstream_format={}\n", h.particle_count,
                 radius ? ":radius:R:1" : "", property_column, h.version);
  const double rstep = (double(h.radius_max) - double(h.radius_min)) / double(store::kQuantMax);
  store::NodeData node;
  std::vector<uint8_t> scratch;
  const auto nodes = reader->nodes();
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    MDS_TRY(reader->read_node(i, node, scratch));
    const store::NodeEntry& e = nodes[i];
    const double step[3] = {store::quant_step(e, 0), store::quant_step(e, 1), store::quant_step(e, 2)};
    for (size_t k = 0; k < node.particle_count(); ++k) {
      double x[3];
      for (int a = 0; a < 3; ++a) x[a] = e.center_min[a] + double(node.qpos[3 * k + a]) * step[a];
      auto it = std::back_inserter(buf);
      fmt::format_to(it, "{} {} {} {}", species[node.type_index[k]], x[0], x[1], x[2]);
      if (radius) fmt::format_to(it, " {}", double(h.radius_min) + double(node.radius_q[k]) * rstep);
      if (property) fmt::format_to(it, " {}", store::property_value(h.property_min, h.property_max, node.property_q[k]));
      buf.push_back('\n');
    }
    if (buf.size() > (size_t(1) << 20)) {
      MDS_TRY(w.write(buf.data(), buf.size()));
      buf.clear();
    }
  }
  MDS_TRY(w.write(buf.data(), buf.size()));
  MDS_TRY(w.flush());
  return out.commit();
}

void setup_export(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<ExportOptions>();
  sub.add_option("store", opt->store, "Store file (.mds)")->required();
  sub.add_option("-o,--output", opt->output, "Output extended XYZ file")->required();
  sub.callback([opt, &exit_code] {
    Status st = export_xyz(*opt);
    exit_code = st.ok() ? 0 : report("export", st.error());
  });
}

Registrar reg("export", "Decode a store (.mds) to extended XYZ", setup_export);

}  // namespace
}  // namespace mds::cli
