// The one exported symbol of libmdstream_h5md.so (readers/h5md_module.h): the H5MD reader's
// entry points. Everything else in the module is hidden (-fvisibility=hidden and
// --exclude-libs for the static libraries it contains).
#include "h5md/h5md_reader.h"
#include "readers/h5md_module.h"

extern "C" __attribute__((visibility("default"))) const void* mdstream_h5md_module() {
  static const mds::H5mdModuleApi api{mds::kH5mdModuleAbi, &mds::H5mdReader::open, &mds::hdf5_has_h5md_group};
  return &api;
}
