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
  }
  return f;
}

Error ExportFilter::nothing_kept(const std::string& store) const {
  if (!threshold) return Error{Errc::invalid_argument, store + ": --slice leaves no particle of the store"};
  return Error{Errc::invalid_argument, store + (slices.empty() ? ": --threshold " : ": --slice with --threshold ") +
                                           store::threshold_spec(*threshold) + " leaves no particle of the store"};
}

}  // namespace mds::cli
