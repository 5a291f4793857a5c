// H5MD input through a loadable module (core/module_loader.h). The H5MD reader (h5md/h5md_reader.h) is the one part of
// mdstream that needs HDF5, whose shared library brings 34 more (curl, gnutls, krb5, ...): linked
// into the CLI they cost 12.7 ms of every process start on the 2-core VM (an empty program: 2.0
// ms, linked with -lhdf5: 14.7 ms, medians of 21), also for `info`, `render` or a LAMMPS
// conversion that never opens an HDF5 file. So the reader is built into libmdstream_h5md.so and
// opened (dlopen) the first time an input turns out to be an HDF5 file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>

#include "readers/reader.h"

namespace mds {

// The module's entry points, returned (as const void*, core/module_loader.h) by its one exported
// function (kH5mdModuleSymbol). Both
// sides are compiled from this header in one build; kH5mdModuleAbi changes with the table or
// with any type it passes (ParticleReader, ReaderOptions, Result).
inline constexpr uint32_t kH5mdModuleAbi = 2;  // 2: FrameInfo::frame_count, ReaderOptions::start
inline constexpr const char* kH5mdModuleSymbol = "mdstream_h5md_module";
inline constexpr const char* kH5mdModuleFile = "libmdstream_h5md.so";

struct H5mdModuleApi {
  uint32_t abi = 0;
  Result<std::unique_ptr<ParticleReader>> (*open)(const std::filesystem::path& path, const ReaderOptions& options) =
      nullptr;
  Result<bool> (*has_h5md_group)(const std::filesystem::path& path) = nullptr;
};

// The loaded module (loaded once per process, never unloaded), or an error that names every
// place looked in and why each failed.
Result<const H5mdModuleApi*> h5md_module();

// True when `path` is an HDF5 file with a /h5md group, false for one without (through the module).
Result<bool> h5md_detect(const std::filesystem::path& path);

}  // namespace mds
