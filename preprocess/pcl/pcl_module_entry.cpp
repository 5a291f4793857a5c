// The one exported symbol of libmdstream_pcl.so (convert/meshlet_pcl_module.h): the PCL meshlet
// builder's factory. Everything else in the module is hidden (-fvisibility=hidden and
// --exclude-libs for the static libraries it contains).
#include "convert/meshlet_pcl_module.h"
#include "pcl/meshlet_pcl.h"

namespace {
std::unique_ptr<mds::convert::MeshletBuilder> make_pcl_builder() {
  return std::make_unique<mds::convert::PclMeshletBuilder>();
}
}  // namespace

extern "C" __attribute__((visibility("default"))) const void* mdstream_pcl_module() {
  static const mds::convert::PclModuleApi api{mds::convert::kPclModuleAbi, &make_pcl_builder};
  return &api;
}
