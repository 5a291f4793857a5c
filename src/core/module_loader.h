// mdstream's optional modules: shared objects built with the executable and opened (dlopen) only
// by the commands and inputs that need them, so that their libraries do not cost every process
// start. Each library loaded at start costs the 2-core VM about 1-4 ms (mapping, relocation,
// page faults); an empty program linked with -lhdf5 took 14.7 ms against 2.0 ms. The modules:
//   libmdstream_h5md.so   the H5MD reader (HDF5), readers/h5md_module.h
//   libmdstream_pcl.so    the PCL meshlet builder (PCL, OpenMP), convert/meshlet_pcl_module.h
//   libmdstream_vulkan.so the render, stress and view commands (Vulkan, GLFW, libpng, tinyexr),
//                         cli/vulkan_module.h
//
// A module is looked up in the folder of the running executable, then in the build folder it was
// built in (test executables live one level below); $MDSTREAM_MODULE_DIR, when set, is the only
// place looked in. A module exports one function, `symbol`, returning a table of entry points;
// both sides are compiled from one header in one build and the table starts with an ABI number
// that the caller checks.
#pragma once

#include "core/result.h"

namespace mds {

using ModuleEntry = const void* (*)();

// The table returned by `symbol` in `file`, from the first place where the file loads, has the
// symbol and accept(table) is true. The module stays loaded for the life of the process. The
// error names `what` needs it, and every place looked in and why each failed.
Result<const void*> load_module(const char* file, const char* symbol, bool (*accept)(const void* table),
                                const char* what);

}  // namespace mds
