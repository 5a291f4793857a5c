// `mdstream export STORE -o OUT.xyz`: a frame of extended XYZ; see export_nodes.h.
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli/export_nodes.h"

namespace mds::cli {

Status write_xyz_frame(const ExportFrame& f, store::BufferedWriter& w) {
  const store::StoreReader& reader = f.reader;
  const store::FileHeader& h = reader.header();
  const bool radius = (h.flags & store::kFlagPerParticleRadius) != 0;
  const bool property = (h.flags & store::kFlagProperty) != 0;
  const bool color = (h.flags & store::kFlagColor) != 0;
  std::string property_name = property ? std::string(h.property_name) : "";
  for (char& c : property_name)  // a token of the Properties triples (an H5MD element may hold these)
    if (c == ':' || c == '=' || c == '"' || c == ' ' || c == '\t') c = '_';
  const std::string property_column = property ? fmt::format(":{}:R:1", property_name) : "";
  std::vector<std::string> species;
  for (const auto& t : reader.types()) {
    std::string name = t.name[0] ? std::string(t.name) : std::to_string(t.input_id);
    for (char& c : name)
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r') c = '_';  // one token per column
    species.push_back(std::move(name));
  }

  fmt::memory_buffer buf;
  // The cell as OVITO and ASE write it (Lattice: a, b, c; Origin; pbc), %.17g: read back exactly.
  std::string cell_keys;
  if (const auto& c = reader.cell()) {
    const auto& v = c->vectors;
    cell_keys = fmt::format(
        "Lattice=\"{:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}\" Origin=\"{:.17g} {:.17g} "
        "{:.17g}\" pbc=\"{} {} {}\" ",
        v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2], v[2][0], v[2][1], v[2][2], c->origin[0], c->origin[1],
        c->origin[2], c->periodic[0] ? 'T' : 'F', c->periodic[1] ? 'T' : 'F', c->periodic[2] ? 'T' : 'F');
  }
  const std::string time_key = f.time ? fmt::format(" Time={}", *f.time) : "";
  fmt::format_to(std::back_inserter(buf), "{}\n{}Properties=species:S:1:pos:R:3{}{}{}{} mdstream_format={}\n", f.count,
                 cell_keys, radius ? ":radius:R:1" : "", property_column, color ? ":color:R:3" : "", time_key,
                 h.version);
  const double rstep = (double(h.radius_max) - double(h.radius_min)) / double(store::kQuantMax);
  const auto line = [&](fmt::memory_buffer& b, const store::NodeData& node, size_t k, const std::array<double, 3>& x) {
    auto it = std::back_inserter(b);
    fmt::format_to(it, "{} {} {} {}", species[node.type_index[k]], x[0], x[1], x[2]);
    if (radius) fmt::format_to(it, " {}", double(h.radius_min) + double(node.radius_q[k]) * rstep);
    if (property) fmt::format_to(it, " {}", store::property_value(h.property_min, h.property_max, node.property_q[k]));
    if (color) {  // channels in [0, 1] (OVITO's Color); 5 digits give the 8-bit value back exactly
      const uint32_t c = node.color[k];
      fmt::format_to(it, " {:.5g} {:.5g} {:.5g}", double(c & 0xffu) / 255.0, double((c >> 8) & 0xffu) / 255.0,
                     double((c >> 16) & 0xffu) / 255.0);
    }
    b.push_back('\n');
  };
  return write_kept_lines(reader, f.filter, w, buf, line);
}

}  // namespace mds::cli
