// What `mdstream export` shares between its formats (cmd_export.cpp: extended XYZ,
// export_mmpld.cpp: MMPLD): which nodes the slices cut, the decoded centre of a particle, and
// which particles --slice and --threshold keep (nodes whose property histogram holds no kept
// value are not read).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"
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
