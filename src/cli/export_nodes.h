// What `mdstream export` shares between its formats (cmd_export.cpp: extended XYZ,
// export_mmpld.cpp: MMPLD): which nodes the slices cut, and the decoded centre of a particle.
#pragma once

#include <array>
#include <filesystem>
#include <span>

#include "core/result.h"
#include "store/slice.h"
#include "store/store_reader.h"

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

// Writes the particles of `reader` that the slices keep to `output` as MMPLD 1.0 (MegaMol's
// particle list data; the layout is readers/mmpld_reader.h's): one frame, one list per type in
// type-index order (a list may be empty), float32 positions; vertex type FLOAT_XYZ with the
// type's radius as the list's global radius, or FLOAT_XYZR with per-particle radii; colour type
// UINT8_RGBA with the store's colours (kFlagColor), else FLOAT_I with its property (kFlagProperty,
// intensity range = the property's range), else NONE with the type's default colour. One pass
// over the nodes (with slices, a first one decodes the nodes they keep any of, for the counts);
// memory bounded by one write buffer per type. The file appears only when complete.
Status export_mmpld(const store::StoreReader& reader, std::span<const store::Slice> slices,
                    const std::filesystem::path& output);

}  // namespace mds::cli
