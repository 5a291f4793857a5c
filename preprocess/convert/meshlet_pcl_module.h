// The PCL meshlet builder through a loadable module (core/module_loader.h). PCL's libraries and
// OpenMP, which PCL links, cost about 4 ms of every process start on the 2-core VM (an empty
// program: 2.9 ms, linked with -lpcl_kdtree -lpcl_common: 6.8 ms, medians of 40), also for
// `info`, `render` or an octree conversion. So the builder (pcl/meshlet_pcl.h) is built into
// libmdstream_pcl.so, which the converter opens when `--meshlet-builder pcl` (the default) is
// asked for.
#pragma once

#include <cstdint>
#include <memory>

#include "convert/meshlet_builder.h"
#include "core/result.h"

namespace mds::convert {

// The module's entry points, returned (as const void*) by its one exported function
// (kPclModuleSymbol). Both sides are compiled from this header in one build; kPclModuleAbi
// changes with the table or with MeshletBuilder.
inline constexpr uint32_t kPclModuleAbi = 1;
inline constexpr const char* kPclModuleSymbol = "mdstream_pcl_module";
inline constexpr const char* kPclModuleFile = "libmdstream_pcl.so";

struct PclModuleApi {
  uint32_t abi = 0;
  std::unique_ptr<MeshletBuilder> (*make_builder)() = nullptr;
};

// The loaded module (loaded once per process, never unloaded), or an error that names every
// place looked in and why each failed.
Result<const PclModuleApi*> pcl_module();

}  // namespace mds::convert
