// Loading of the H5MD reader module (see h5md_module.h).
#include "readers/h5md_module.h"

#include <dlfcn.h>

#include <cstdlib>
#include <string>
#include <system_error>
#include <vector>

#include "readers/reader_factories.h"

namespace mds {

namespace {

std::vector<std::filesystem::path> module_dirs() {
  std::vector<std::filesystem::path> dirs;
  if (const char* e = std::getenv("MDSTREAM_MODULE_DIR"); e && *e) return {e};  // set: the only place
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back(exe.parent_path());
#ifdef MDSTREAM_BUILD_MODULE_DIR
  dirs.emplace_back(MDSTREAM_BUILD_MODULE_DIR);
#endif
  return dirs;
}

Result<const H5mdModuleApi*> load_module() {
  std::string tried;
  for (const auto& dir : module_dirs()) {
    const std::filesystem::path file = dir / kH5mdModuleFile;
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) {
      tried += "\n  " + file.string() + ": no such file";
      continue;
    }
    void* handle = ::dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = ::dlerror();
      tried += "\n  " + file.string() + ": " + (why ? why : "dlopen failed");
      continue;
    }
    auto entry = reinterpret_cast<H5mdModuleEntry>(::dlsym(handle, kH5mdModuleSymbol));
    const H5mdModuleApi* api = entry ? entry() : nullptr;
    if (!api || api->abi != kH5mdModuleAbi || !api->open || !api->has_h5md_group) {
      tried += "\n  " + file.string() + ": not an mdstream H5MD module of this build (ABI " +
               std::to_string(kH5mdModuleAbi) + ")";
      ::dlclose(handle);
      continue;
    }
    return api;  // the handle stays open for the life of the process (readers use its code)
  }
  return make_error(Errc::unsupported, "H5MD input needs the module {} (next to the mdstream executable); tried:{}",
                    kH5mdModuleFile, tried);
}

}  // namespace

Result<const H5mdModuleApi*> h5md_module() {
  static const Result<const H5mdModuleApi*> loaded = load_module();  // thread-safe, once
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
