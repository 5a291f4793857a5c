// `mdstream export STORE -o OUT.lammpstrj` (or OUT.data): the store as a LAMMPS text dump or data
// file; see export_nodes.h.
// The box conventions are the reader's (readers/lammps_reader.h: a triclinic dump writes the
// bounding box and the tilts, lammps_box_from_cell).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli/export_nodes.h"
#include "readers/lammps_reader.h"
#include "store/file_io.h"

namespace mds::cli {
namespace {

// A name as one whitespace-free token of an atom line.
std::string token(std::string s) {
  for (char& c : s)
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') c = '_';
  return s;
}

// What a LAMMPS file (dump or data) says of the store beside its atoms: the box, the periodic
// axes, and the LAMMPS type (and element name) of each store type.
struct LammpsLayout {
  LammpsBox box;
  bool periodic[3] = {false, false, false};
  std::vector<int64_t> type_id;      // per type index
  std::vector<std::string> element;  // per type index, when some type has a name (else empty)
  int64_t type_count = 0;            // the largest type id (a data file's "atom types")
};

// `what` names the file kind for the error of a cell LAMMPS cannot hold; `types`: the export's
// numbering (nullptr: this store's alone).
Result<LammpsLayout> lammps_layout(const store::StoreReader& reader, const LammpsTypes* types, const char* what) {
  const store::FileHeader& h = reader.header();
  LammpsLayout l;
  // The spheres' box: the centres' bounds grown by the largest radius (0.5 without radii, so that
  // a flat sheet still has a thickness), as the MMPLD export's: every atom inside it.
  const double pad = h.radius_max > 0.0f ? double(h.radius_max) : 0.5;
  if (const auto& c = reader.cell()) {
    auto b = lammps_box_from_cell(*c);
    if (!b.ok())
      return make_error(Errc::unsupported, "{}: {}; a LAMMPS {} cannot hold it (export to .xyz keeps the cell)",
                        reader.path().string(), b.error().message, what);
    l.box = *b;
    std::copy_n(c->periodic, 3, l.periodic);
    // A non-periodic axis of an orthogonal cell holds the atoms beyond the cell too (a molecule
    // in a box drawn for it): LAMMPS loses atoms outside a non-periodic box.
    if (!l.box.triclinic)
      for (int d = 0; d < 3; ++d)
        if (!l.periodic[d]) {
          l.box.lo[d] = l.box.bound_lo[d] = std::min(l.box.lo[d], h.bounds_min[d] - pad);
          l.box.hi[d] = l.box.bound_hi[d] = std::max(l.box.hi[d], h.bounds_max[d] + pad);
        }
  } else {
    for (int d = 0; d < 3; ++d) {
      l.box.lo[d] = l.box.bound_lo[d] = h.bounds_min[d] - pad;
      l.box.hi[d] = l.box.bound_hi[d] = h.bounds_max[d] + pad;
    }
  }
  const auto entries = reader.types();
  LammpsTypes own;
  if (!types) {
    own = lammps_types(std::vector<std::vector<store::TypeEntry>>{{entries.begin(), entries.end()}});
    types = &own;
  }
  for (const auto& t : entries) {
    l.type_id.push_back(types->id_of.at(lammps_type_key(t)));
    const std::string name(t.name, strnlen(t.name, sizeof(t.name)));
    if (types->names) l.element.push_back(token(name.empty() ? std::to_string(t.input_id) : name));
  }
  l.type_count = types->count;
  return l;
}

}  // namespace

std::string lammps_type_key(const store::TypeEntry& t) {
  const std::string name(t.name, strnlen(t.name, sizeof(t.name)));
  return name.empty() ? "\t#" + std::to_string(t.input_id) : name;  // a tab: in no name
}

LammpsTypes lammps_types(std::span<const std::vector<store::TypeEntry>> stores) {
  LammpsTypes l;
  std::vector<std::string> keys;  // in the order the stores list them
  std::set<std::string> seen;
  int64_t max_id = 0;
  bool by_id = true;
  for (const auto& types : stores)
    for (const auto& t : types) {
      const std::string k = lammps_type_key(t);
      if (k[0] != '\t') l.names = true;
      if (t.input_id < 1) by_id = false;
      max_id = std::max<int64_t>(max_id, t.input_id);
      if (seen.insert(k).second) keys.push_back(k);
    }
  by_id = by_id && !l.names && max_id <= 4 * int64_t(keys.size()) + 16;
  for (size_t i = 0; i < keys.size(); ++i) {
    const int64_t id = by_id ? std::stoll(keys[i].substr(2)) : int64_t(i) + 1;
    l.id_of[keys[i]] = id;
    l.count = std::max(l.count, id);
  }
  return l;
}

Status write_lammps_frame(const ExportFrame& f, store::BufferedWriter& w) {
  const store::StoreReader& reader = f.reader;
  const store::FileHeader& h = reader.header();
  MDS_ASSIGN_OR_RETURN(const LammpsLayout l, lammps_layout(reader, f.types, "dump"));
  const LammpsBox& box = l.box;
  const bool* periodic = l.periodic;
  const bool any_name = !l.element.empty();
  const std::vector<int64_t>& type_id = l.type_id;
  const std::vector<std::string>& element = l.element;
  const bool radius = (h.flags & store::kFlagPerParticleRadius) != 0;
  const bool property = (h.flags & store::kFlagProperty) != 0;

  fmt::memory_buffer buf;
  auto it = std::back_inserter(buf);
  // A whole time is the step (a LAMMPS input's); another goes to ITEM: TIME, the index to TIMESTEP.
  int64_t step = 0;
  if (f.time) {
    if (f.time_is_step) {
      step = int64_t(*f.time);
    } else {
      step = f.index;
      fmt::format_to(it, "ITEM: TIME\n{}\n", *f.time);
    }
  }
  fmt::format_to(it, "ITEM: TIMESTEP\n{}\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS {}{} {} {}\n", step, f.count,
                 box.triclinic ? "xy xz yz " : "", periodic[0] ? "pp" : "ff", periodic[1] ? "pp" : "ff",
                 periodic[2] ? "pp" : "ff");
  const double tilt[3] = {box.xy, box.xz, box.yz};
  for (int d = 0; d < 3; ++d) {
    fmt::format_to(it, "{} {}", box.bound_lo[d], box.bound_hi[d]);
    if (box.triclinic) fmt::format_to(it, " {}", tilt[d]);
    buf.push_back('\n');
  }
  std::string property_column = property ? token(h.property_name) : "";
  for (const char* taken : {"id", "type", "x", "y", "z", "radius", "element"})
    if (property_column == taken) property_column = "p_" + property_column;
  fmt::format_to(it, "ITEM: ATOMS id type x y z{}{}{}\n", radius ? " radius" : "",
                 property ? " " + property_column : "", any_name ? " element" : "");
  const double rstep = (double(h.radius_max) - double(h.radius_min)) / double(store::kQuantMax);
  uint64_t id = 0;
  const auto line = [&](fmt::memory_buffer& b, const store::NodeData& node, size_t k, const std::array<double, 3>& x) {
    auto o = std::back_inserter(b);
    const uint8_t t = node.type_index[k];
    fmt::format_to(o, "{} {} {} {} {}", ++id, type_id[t], x[0], x[1], x[2]);
    if (radius) fmt::format_to(o, " {}", double(h.radius_min) + double(node.radius_q[k]) * rstep);
    if (property) fmt::format_to(o, " {}", store::property_value(h.property_min, h.property_max, node.property_q[k]));
    if (any_name) fmt::format_to(o, " {}", element[t]);
    b.push_back('\n');
  };
  return write_kept_lines(reader, f.filter, w, buf, line);
}

Status write_lammps_data(const ExportFrame& f, store::BufferedWriter& w) {
  const store::StoreReader& reader = f.reader;
  const store::FileHeader& h = reader.header();
  MDS_ASSIGN_OR_RETURN(const LammpsLayout l, lammps_layout(reader, f.types, "data file"));
  const bool sphere = (h.flags & store::kFlagPerParticleRadius) != 0;
  fmt::memory_buffer buf;
  auto it = std::back_inserter(buf);
  fmt::format_to(it, "LAMMPS data file from mdstream export of {}\n\n{} atoms\n{} atom types\n\n",
                 reader.path().filename().string(), f.count, l.type_count);
  const char* axis[3] = {"x", "y", "z"};
  for (int d = 0; d < 3; ++d) fmt::format_to(it, "{} {} {}lo {}hi\n", l.box.lo[d], l.box.hi[d], axis[d], axis[d]);
  if (l.box.triclinic) fmt::format_to(it, "{} {} {} xy xz yz\n", l.box.xy, l.box.xz, l.box.yz);
  fmt::format_to(it, "\nAtoms # {}\n\n", sphere ? "sphere" : "atomic");
  const double rstep = (double(h.radius_max) - double(h.radius_min)) / double(store::kQuantMax);
  uint64_t id = 0;
  const auto line = [&](fmt::memory_buffer& b, const store::NodeData& node, size_t k, const std::array<double, 3>& x) {
    auto o = std::back_inserter(b);
    fmt::format_to(o, "{} {}", ++id, l.type_id[node.type_index[k]]);
    if (sphere) fmt::format_to(o, " {} 1", 2.0 * (double(h.radius_min) + double(node.radius_q[k]) * rstep));  // diameter, density
    fmt::format_to(o, " {} {} {}\n", x[0], x[1], x[2]);
  };
  return write_kept_lines(reader, f.filter, w, buf, line);
}

}  // namespace mds::cli
