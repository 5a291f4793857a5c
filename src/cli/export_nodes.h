// What `mdstream export` shares between its formats (cmd_export.cpp: extended XYZ,
// export_mmpld.cpp: MMPLD): which nodes the slices cut, the decoded centre of a particle, and
// which particles --slice and --threshold keep (nodes whose property histogram holds no kept
// value are not read).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/result.h"
#include "store/file_io.h"
#include "store/property_histogram.h"
#include "store/slice.h"
#include "store/store_reader.h"
#include "store/threshold.h"

namespace mds::cli {

// What the slices do to node e (slices_cover over its decoded box).
inline store::SliceCover node_cover(std::span<const store::Slice> slices, const store::NodeEntry& e) {
  if (slices.empty()) return store::SliceCover::all;
  std::array<double, 3> lo, hi;
  store::decoded_box(e.center_min, e.center_max, lo, hi);
  return store::slices_cover(slices, lo, hi);
}

// The centre of particle k of a decoded node (x = center_min + q * step, in double).
inline std::array<double, 3> centre(const store::NodeEntry& e, const store::NodeData& node, size_t k) {
  std::array<double, 3> x;
  for (int a = 0; a < 3; ++a) x[size_t(a)] = e.center_min[a] + double(node.qpos[3 * k + size_t(a)]) * store::quant_step(e, a);
  return x;
}

// The particles export writes: those every slice keeps by their centre and the threshold keeps by
// their property value (the ones `render --slice --threshold` draws).
struct ExportFilter {
  std::vector<store::Slice> slices;
  std::optional<store::Threshold> threshold;
  std::vector<uint8_t> property_kept;  // store::threshold_table over the store's range; empty: no threshold
  // With a threshold on a store with property histograms: store::kept_prefix_sums of
  // property_kept and the store's histograms, so that nodes with no kept value are not read.
  std::vector<uint32_t> kept_prefix;
  std::span<const store::PropertyHistogram> histograms;

  // From the --slice specs and the --threshold spec (empty: none) for `reader`'s store;
  // Errc::invalid_argument naming the option for a bad spec, or --threshold on a store without a
  // per-particle property.
  static Result<ExportFilter> make(std::span<const std::string> slice_specs, const std::string& threshold,
                                   const store::StoreReader& reader);
  // Leaves particles out.
  bool any() const { return !slices.empty() || threshold.has_value(); }
  // Whether particle k (centre x) of a node covered as `cover` (cover(), not none) is kept.
  bool keeps(store::SliceCover cover, const std::array<double, 3>& x, const store::NodeData& node, size_t k) const {
    if (cover == store::SliceCover::some && !store::slices_keep(slices, x)) return false;
    return property_kept.empty() || property_kept[node.property_q[k]];
  }
  // What the slices and the threshold do to node i (entry e): none (not read), all (every
  // particle kept: a threshold whose histogram says so, or none), or some.
  store::SliceCover cover(uint32_t i, const store::NodeEntry& e) const;
  // Every particle of a node covered as `cover` (cover()) is kept, without decoding it.
  bool keeps_whole(store::SliceCover cover) const { return cover == store::SliceCover::all; }
  // The error when nothing is kept, naming the store, the options and the property's range.
  Error nothing_kept(const store::StoreReader& reader) const;
};

// The particles the filter keeps: the store's count without a filter; with one, nodes kept whole
// or left out count from the directory and the others are decoded.
Result<uint64_t> kept_count(const store::StoreReader& reader, const ExportFilter& filter);

// Calls particle(e, node, k, x) for every particle the filter keeps, in store order (node entry
// e, its decoded data, the particle's index in it and its centre), and node_done() -> Status after
// each node it read; nodes the filter leaves out are not read. Read errors are returned.
template <class Particle, class NodeDone>
Status for_each_kept(const store::StoreReader& reader, const ExportFilter& filter, Particle&& particle,
                     NodeDone&& node_done) {
  store::NodeData node;
  std::vector<uint8_t> scratch;
  const auto nodes = reader.nodes();
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    const store::NodeEntry& e = nodes[i];
    const store::SliceCover cover = filter.cover(i, e);
    if (cover == store::SliceCover::none) continue;
    MDS_TRY(reader.read_node(i, node, scratch));
    for (size_t k = 0; k < node.particle_count(); ++k) {
      const std::array<double, 3> x = centre(e, node, k);
      if (filter.keeps(cover, x, node, k)) particle(e, node, k, x);
    }
    MDS_TRY(node_done());
  }
  return {};
}

// The text writers' loop (XYZ, LAMMPS dump): line(buf, node, k, x) appends the line of every kept
// particle to `buf`, which goes to `w` whenever it passes 1 MiB and at the end.
template <class Line>
Status write_kept_lines(const store::StoreReader& reader, const ExportFilter& filter, store::BufferedWriter& w,
                        fmt::memory_buffer& buf, Line&& line) {
  const auto particle = [&](const store::NodeEntry&, const store::NodeData& node, size_t k,
                            const std::array<double, 3>& x) { line(buf, node, k, x); };
  const auto flush_full = [&]() -> Status {
    if (buf.size() <= (size_t(1) << 20)) return {};
    MDS_TRY(w.write(buf.data(), buf.size()));
    buf.clear();
    return {};
  };
  MDS_TRY(for_each_kept(reader, filter, particle, flush_full));
  return w.write(buf.data(), buf.size());
}

// One frame of a text export (extended XYZ, LAMMPS dump): a store, what its filter keeps, and
// where it stands in a series.
// The LAMMPS type of each particle type over every store of an export (dump, data file), so
// that a type keeps its number in every frame of a series: a type is known by its name, else by
// its input id. The input ids are the numbers when no type has a name and the ids are positive
// and at most 4 x their count + 16 (a data file declares as many types as the largest); else the
// keys are numbered 1, 2, .. in the order the stores list them.
struct LammpsTypes {
  std::map<std::string, int64_t> id_of;  // key (lammps_type_key) -> LAMMPS type
  bool names = false;                    // some type has a name: the element column
  int64_t count = 0;                     // the largest LAMMPS type
};
std::string lammps_type_key(const store::TypeEntry& t);
LammpsTypes lammps_types(std::span<const std::vector<store::TypeEntry>> stores);

struct ExportFrame {
  const store::StoreReader& reader;
  const ExportFilter& filter;
  uint64_t count = 0;          // kept_count(reader, filter)
  std::optional<double> time;  // the series frame's time (none for one store)
  int64_t index = 0;           // the series index (0 for one store)
  // Dump: TIMESTEP is the time (every picked time a whole, distinct number: a LAMMPS input's
  // steps), else the series index after ITEM: TIME with the time, in every frame alike.
  bool time_is_step = false;
  const LammpsTypes* types = nullptr;  // dump, data file: every picked store's numbering (nullptr: this store's)
};

// Appends the frame as extended XYZ (export_xyz.cpp): the count line, the comment line (the cell
// as Lattice, Origin and pbc; Properties=species:S:1:pos:R:3 then radius, the property and
// color:R:3 where the store has them; Time=<time> in a series), one line per kept particle in
// store order. Numbers in shortest round-trip form, colours with 5 digits (the 8 bits back exactly).
Status write_xyz_frame(const ExportFrame& f, store::BufferedWriter& w);

// Appends the frame as a LAMMPS text dump (export_lammps.cpp; dump custom: ITEM: TIMESTEP,
// NUMBER OF ATOMS, BOX BOUNDS, ATOMS id type x y z [radius] [property] [element]), readable by
// LAMMPS' read_dump, OVITO and `mdstream convert`. The timestep: see ExportFrame::time_is_step;
// 0 for one store. The box is the store's cell when LAMMPS can hold it (pp for a periodic axis,
// else ff, widened along a non-periodic axis of an orthogonal cell to hold the spheres; triclinic
// with its tilts), else the spheres' box (the centres' bounds grown by the largest radius, 0.5
// without radii; ff), and an error for a cell it cannot (a rotated one: .xyz keeps it). Types as
// LammpsTypes numbers them; `element` holds the types' names when any has one. A property named
// like another column (id, type, x, y, z, radius, element) is written as p_<name>. Ids number the frame's particles 1..N in store order (the store keeps no input
// ids: they do not follow a particle across frames). Numbers in shortest round-trip form.
Status write_lammps_frame(const ExportFrame& f, store::BufferedWriter& w);

// Writes the frame as a LAMMPS data file (read_data): "N atoms", "M atom types" (M the largest
// type id), the box as write_frame's (lo hi per axis, "xy xz yz" when tilted; a data file has no
// periodicity: the input's `boundary` sets it), then "Atoms # atomic" (id type x y z) or, with
// per-particle radii, "Atoms # sphere" (id type diameter density=1 x y z). Types and ids as in
// the dump. One frame per file.
Status write_lammps_data(const ExportFrame& f, store::BufferedWriter& w);

// Writes the particles of `reader` that the filter keeps to `output` as MMPLD 1.0 (MegaMol's
// particle list data; the layout is readers/mmpld_reader.h's): one frame, its bounding box the
// store's simulation cell's (else the spheres'), one list per type in
// type-index order (a list may be empty), float32 positions; vertex type FLOAT_XYZ with the
// type's radius as the list's global radius, or FLOAT_XYZR with per-particle radii; colour type
// UINT8_RGBA with the store's colours (kFlagColor), else FLOAT_I with its property (kFlagProperty,
// intensity range = the property's range), else NONE with the type's default colour. One pass
// over the nodes (with a filter, a first one decodes the nodes it may keep any of, for the counts);
// memory bounded by one write buffer per type. The file appears only when complete.
Status export_mmpld(const store::StoreReader& reader, const ExportFilter& filter, const std::filesystem::path& output);

}  // namespace mds::cli
