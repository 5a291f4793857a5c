// Loading of the H5MD reader module (see h5md_module.h).
#include "readers/h5md_module.h"

#include "core/module_loader.h"
#include "readers/reader_factories.h"

namespace mds {

namespace {

bool accept_h5md(const void* table) {
  const auto* api = static_cast<const H5mdModuleApi*>(table);
  return api->abi == kH5mdModuleAbi && api->open && api->has_h5md_group;
}

Result<const H5mdModuleApi*> load_h5md_module() {
  MDS_ASSIGN_OR_RETURN(const void* table, load_module(kH5mdModuleFile, kH5mdModuleSymbol, accept_h5md, "H5MD input"));
  return static_cast<const H5mdModuleApi*>(table);
}

}  // namespace

Result<const H5mdModuleApi*> h5md_module() {
  static const Result<const H5mdModuleApi*> loaded = load_h5md_module();  // thread-safe, once
  return loaded;
}

namespace {

// The module, or its loading error prefixed with the input that needed it.
Result<const H5mdModuleApi*> module_for(const std::filesystem::path& path) {
  auto m = h5md_module();
  if (!m.ok()) return make_error(m.error().code, "{}: {}", path.string(), m.error().message);
  return m;
}

}  // namespace

Result<bool> h5md_detect(const std::filesystem::path& path) {
  MDS_ASSIGN_OR_RETURN(const H5mdModuleApi* api, module_for(path));
  return api->has_h5md_group(path);
}

Result<std::unique_ptr<ParticleReader>> open_h5md_reader(const std::filesystem::path& path,
                                                         const ReaderOptions& options) {
  MDS_ASSIGN_OR_RETURN(const H5mdModuleApi* api, module_for(path));
  return api->open(path, options);
}

}  // namespace mds
