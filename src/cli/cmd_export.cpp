// `mdstream export STORE -o OUT.xyz [--slice SPEC ...] [--threshold LO:HI]`: decodes every node and writes extended
// XYZ (species, dequantized positions x = center_min + q * step, and the per-particle radius,
// property and colour (color:R:3, alpha dropped) when the store has them). Numbers are printed
// in shortest round-trip form (colours with 5 digits, which give the 8 bits back exactly), so
// the export adds no error to the store's quantization error. With slices (store/slice.h) and a
// threshold (store/threshold.h) only the particles they keep, the same ones `render --slice
// --threshold` draws; nodes the slices leave out, or whose property histogram holds no value the
// threshold keeps, are not read. The output appears only when complete. `-o OUT.mmpld` writes MMPLD instead
// (export_mmpld.cpp), `-o OUT.lammpstrj` (or .dump) a LAMMPS dump (export_lammps.cpp).
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli/command.h"
#include "cli/export_nodes.h"
#include "store/file_io.h"
#include "store/slice.h"
#include "store/store_reader.h"

namespace mds::cli {
namespace {

struct ExportOptions {
  std::string store;
  std::string output;
  std::vector<std::string> slices;  // --slice specs
  std::string threshold;            // --threshold spec
};

Status export_xyz(const ExportOptions& o) {
  MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(o.store));
  MDS_ASSIGN_OR_RETURN(const ExportFilter filter, ExportFilter::make(o.slices, o.threshold, *reader));
  const store::FileHeader& h = reader->header();
  const bool radius = (h.flags & store::kFlagPerParticleRadius) != 0;
  const bool property = (h.flags & store::kFlagProperty) != 0;
  const bool color = (h.flags & store::kFlagColor) != 0;
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

  MDS_ASSIGN_OR_RETURN(const uint64_t count, kept_count(*reader, filter));

  MDS_ASSIGN_OR_RETURN(auto out, store::AtomicOutput::create(o.output));
  store::BufferedWriter w(out.file(), size_t(8) << 20);
  fmt::memory_buffer buf;
  // The cell as OVITO and ASE write it (Lattice: a, b, c; Origin; pbc), %.17g: read back exactly.
  std::string cell_keys;
  if (const auto& c = reader->cell()) {
    const auto& v = c->vectors;
    cell_keys = fmt::format(
        "Lattice=\"{:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}\" Origin=\"{:.17g} {:.17g} "
        "{:.17g}\" pbc=\"{} {} {}\" ",
        v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2], v[2][0], v[2][1], v[2][2], c->origin[0], c->origin[1],
        c->origin[2], c->periodic[0] ? 'T' : 'F', c->periodic[1] ? 'T' : 'F', c->periodic[2] ? 'T' : 'F');
  }
  fmt::format_to(std::back_inserter(buf), "{}\n{}Properties=species:S:1:pos:R:3{}{}{} mdstream_format={}\n", count,
                 cell_keys, radius ? ":radius:R:1" : "", property_column, color ? ":color:R:3" : "", h.version);
  const double rstep = (double(h.radius_max) - double(h.radius_min)) / double(store::kQuantMax);
  const auto write_particle = [&](const store::NodeEntry&, const store::NodeData& node, size_t k,
                                  const std::array<double, 3>& x) {
    auto it = std::back_inserter(buf);
    fmt::format_to(it, "{} {} {} {}", species[node.type_index[k]], x[0], x[1], x[2]);
    if (radius) fmt::format_to(it, " {}", double(h.radius_min) + double(node.radius_q[k]) * rstep);
    if (property) fmt::format_to(it, " {}", store::property_value(h.property_min, h.property_max, node.property_q[k]));
    if (color) {  // channels in [0, 1] (OVITO's Color); 5 digits give the 8-bit value back exactly
      const uint32_t c = node.color[k];
      fmt::format_to(it, " {:.5g} {:.5g} {:.5g}", double(c & 0xffu) / 255.0, double((c >> 8) & 0xffu) / 255.0,
                     double((c >> 16) & 0xffu) / 255.0);
    }
    buf.push_back('\n');
  };
  const auto flush_full = [&]() -> Status {
    if (buf.size() <= (size_t(1) << 20)) return {};
    MDS_TRY(w.write(buf.data(), buf.size()));
    buf.clear();
    return {};
  };
  MDS_TRY(for_each_kept(*reader, filter, write_particle, flush_full));
  MDS_TRY(w.write(buf.data(), buf.size()));
  MDS_TRY(w.flush());
  return out.commit();
}

Status export_mmpld_file(const ExportOptions& o) {
  MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(o.store));
  MDS_ASSIGN_OR_RETURN(const ExportFilter filter, ExportFilter::make(o.slices, o.threshold, *reader));
  return export_mmpld(*reader, filter, o.output);
}

Status export_lammps_file(const ExportOptions& o) {
  MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(o.store));
  MDS_ASSIGN_OR_RETURN(const ExportFilter filter, ExportFilter::make(o.slices, o.threshold, *reader));
  return export_lammps(*reader, filter, o.output);
}

void setup_export(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<ExportOptions>();
  sub.add_option("store", opt->store, "Store file (.mds)")->required();
  sub.add_option("-o,--output", opt->output,
                 "Output file: extended XYZ; a LAMMPS dump (id type x y z, radius, property, element) when it ends "
                 "in .lammpstrj or .dump; MMPLD 1.0 for MegaMol when it ends in .mmpld (one list per type, the "
                 "store's colours, property or type colours)")
      ->required();
  sub.add_option("--slice", opt->slices,
                 "NX,NY,NZ,D[,WIDTH][,invert]: only the particles the slice keeps, as render --slice (docs/rendering.md, "
                 "\"Slices\"); once per slice, all applied")
      ->allow_extra_args(false);
  sub.add_option("--threshold", opt->threshold,
                 "LO:HI[,invert]: only the particles whose per-particle property lies in [LO, HI] (an empty LO or HI: "
                 "open; invert: the others), as render --threshold (docs/rendering.md, \"Thresholds\")");
  sub.callback([opt, &exit_code] {
    std::string ext = std::filesystem::path(opt->output).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    Status st = ext == ".mmpld"                         ? export_mmpld_file(*opt)
                : ext == ".lammpstrj" || ext == ".dump" ? export_lammps_file(*opt)
                                                        : export_xyz(*opt);
    exit_code = st.ok() ? 0 : report("export", st.error());
  });
}

Registrar reg("export", "Decode a store (.mds) to extended XYZ, a LAMMPS dump or MMPLD", setup_export);

}  // namespace
}  // namespace mds::cli
