// `mdstream export STORE -o OUT.lammpstrj`: the store as a LAMMPS text dump; see export_nodes.h.
// The box conventions are the reader's (readers/lammps_reader.h: a triclinic dump writes the
// bounding box and the tilts, lammps_box_from_cell).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
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

}  // namespace

Status write_lammps_frame(const ExportFrame& f, store::BufferedWriter& w) {
  const store::StoreReader& reader = f.reader;
  const store::FileHeader& h = reader.header();
  const auto types = reader.types();
  // The box: the store's cell, else the bounds of the particle centres (not periodic).
  LammpsBox box;
  bool periodic[3] = {false, false, false};
  if (const auto& c = reader.cell()) {
    auto b = lammps_box_from_cell(*c);
    if (!b.ok())
      return make_error(Errc::unsupported, "{}: {}; a LAMMPS dump cannot hold it (export to .xyz keeps the cell)",
                        reader.path().string(), b.error().message);
    box = *b;
    std::copy_n(c->periodic, 3, periodic);
  } else {
    for (int d = 0; d < 3; ++d) {
      box.lo[d] = box.bound_lo[d] = h.bounds_min[d];
      box.hi[d] = box.bound_hi[d] = h.bounds_max[d];
    }
  }
  // LAMMPS types: the input ids when each is a distinct positive integer, else 1 + the index.
  std::set<int32_t> ids;
  bool any_name = false;
  for (const auto& t : types) {
    if (t.input_id >= 1) ids.insert(t.input_id);
    any_name = any_name || t.name[0] != '\0';
  }
  const bool input_ids = ids.size() == types.size();
  std::vector<int64_t> type_id;       // per type index
  std::vector<std::string> element;   // per type index, when any type has a name
  for (size_t i = 0; i < types.size(); ++i) {
    type_id.push_back(input_ids ? int64_t(types[i].input_id) : int64_t(i) + 1);
    const std::string name(types[i].name, strnlen(types[i].name, sizeof(types[i].name)));
    if (any_name) element.push_back(token(name.empty() ? std::to_string(types[i].input_id) : name));
  }
  const bool radius = (h.flags & store::kFlagPerParticleRadius) != 0;
  const bool property = (h.flags & store::kFlagProperty) != 0;

  fmt::memory_buffer buf;
  auto it = std::back_inserter(buf);
  // A whole time is the step (a LAMMPS input's); another goes to ITEM: TIME, the index to TIMESTEP.
  int64_t step = 0;
  if (f.time) {
    const double t = *f.time;
    if (t == std::floor(t) && std::fabs(t) < 9.0e18) {
      step = int64_t(t);
    } else {
      step = f.index;
      fmt::format_to(it, "ITEM: TIME\n{}\n", t);
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
  fmt::format_to(it, "ITEM: ATOMS id type x y z{}{}{}\n", radius ? " radius" : "",
                 property ? " " + token(h.property_name) : "", any_name ? " element" : "");
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

}  // namespace mds::cli
