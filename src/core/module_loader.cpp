// Loading of mdstream's optional modules (see module_loader.h).
#include "core/module_loader.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

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

}  // namespace

Result<const void*> load_module(const char* file, const char* symbol, bool (*accept)(const void* table),
                                const char* what) {
  std::string tried;
  for (const auto& dir : module_dirs()) {
    const std::filesystem::path path = dir / file;
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
      tried += "\n  " + path.string() + ": no such file";
      continue;
    }
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = ::dlerror();
      tried += "\n  " + path.string() + ": " + (why ? why : "dlopen failed");
      continue;
    }
    auto entry = reinterpret_cast<ModuleEntry>(::dlsym(handle, symbol));
    const void* table = entry ? entry() : nullptr;
    if (!table || !accept(table)) {
      tried += "\n  " + path.string() + ": not a module of this mdstream build (" + symbol + ")";
      ::dlclose(handle);
      continue;
    }
    return table;  // the handle stays open for the life of the process (its code is in use)
  }
  return make_error(Errc::unsupported, "{} needs the module {} (next to the mdstream executable); tried:{}", what, file,
                    tried);
}

}  // namespace mds
