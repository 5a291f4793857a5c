// Loading of the PCL meshlet builder module (see meshlet_pcl_module.h).
#include "convert/meshlet_pcl_module.h"

#include "core/module_loader.h"

namespace mds::convert {

namespace {

bool accept_pcl(const void* table) {
  const auto* api = static_cast<const PclModuleApi*>(table);
  return api->abi == kPclModuleAbi && api->make_builder;
}

Result<const PclModuleApi*> load_pcl_module() {
  MDS_ASSIGN_OR_RETURN(const void* table,
                       load_module(kPclModuleFile, kPclModuleSymbol, accept_pcl, "the PCL meshlet builder"));
  return static_cast<const PclModuleApi*>(table);
}

}  // namespace

Result<const PclModuleApi*> pcl_module() {
  static const Result<const PclModuleApi*> loaded = load_pcl_module();  // thread-safe, once
  return loaded;
}

}  // namespace mds::convert
