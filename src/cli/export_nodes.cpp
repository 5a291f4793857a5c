// Which particles `mdstream export` writes (see export_nodes.h).
#include "cli/export_nodes.h"

namespace mds::cli {

Result<ExportFilter> ExportFilter::make(std::span<const std::string> slice_specs, const std::string& threshold,
                                        const store::StoreReader& reader) {
  ExportFilter f;
  MDS_ASSIGN_OR_RETURN(f.slices, store::parse_slices(slice_specs));
  if (!threshold.empty()) {
    auto t = store::parse_threshold(threshold);
    if (!t) return make_error(Errc::invalid_argument, "--threshold {}", t.error().message);
    const store::FileHeader& h = reader.header();
    if (!(h.flags & store::kFlagProperty))
      return make_error(Errc::invalid_argument, "--threshold {}: {} has no per-particle property (convert --property NAME)",
                        threshold, reader.path().string());
    f.threshold = *t;
    f.property_kept = store::threshold_table(*t, h.property_min, h.property_max);
    if (h.flags & store::kFlagPropertyHistogram) {
      f.kept_prefix = store::kept_prefix_sums(f.property_kept);
      f.histograms = reader.property_histograms();
    }
  }
  return f;
}

store::SliceCover ExportFilter::cover(uint32_t i, const store::NodeEntry& e) const {
  const store::SliceCover by_slices = node_cover(slices, e);
  if (property_kept.empty() || by_slices == store::SliceCover::none) return by_slices;
  if (histograms.empty()) return store::SliceCover::some;  // a store without histograms: decode and test
  const store::SliceCover by_value = store::property_cover(histograms[i], kept_prefix).cover;
  if (by_value == store::SliceCover::none) return by_value;
  return by_value == store::SliceCover::all ? by_slices : store::SliceCover::some;
}

Result<uint64_t> kept_count(const store::StoreReader& reader, const ExportFilter& filter) {
  if (!filter.any()) return reader.header().particle_count;
  uint64_t count = 0;
  store::NodeData node;
  std::vector<uint8_t> scratch;
  const auto nodes = reader.nodes();
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    const store::SliceCover cover = filter.cover(i, nodes[i]);
    if (cover == store::SliceCover::none) continue;
    if (filter.keeps_whole(cover)) {
      count += nodes[i].particle_count;
      continue;
    }
    MDS_TRY(reader.read_node(i, node, scratch));
    for (size_t k = 0; k < node.particle_count(); ++k) count += filter.keeps(cover, centre(nodes[i], node, k), node, k);
  }
  return count;
}

Error ExportFilter::nothing_kept(const store::StoreReader& reader) const {
  const std::string store = reader.path().string();
  if (!threshold) return make_error(Errc::invalid_argument, "{}: --slice leaves no particle of the store", store);
  const store::FileHeader& h = reader.header();
  return make_error(Errc::invalid_argument, "{}: {}--threshold {} leaves no particle of the store (its property '{}' "
                    "lies in [{:g}, {:g}])", store, slices.empty() ? "" : "--slice with ", store::threshold_spec(*threshold),
                    h.property_name, h.property_min, h.property_max);
}

}  // namespace mds::cli
