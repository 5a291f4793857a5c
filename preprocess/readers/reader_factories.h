// Per-format reader constructors; open_reader() (open_reader.cpp) dispatches to these.
// Each opens `path`, positions at options.frame and fills the FrameInfo, or returns an
// error naming the file and the place.
#pragma once

#include "readers/reader.h"

namespace mds {

Result<std::unique_ptr<ParticleReader>> open_lammps_reader(const std::filesystem::path& path, const ReaderOptions& options);
Result<std::unique_ptr<ParticleReader>> open_xyz_reader(const std::filesystem::path& path, const ReaderOptions& options);
Result<std::unique_ptr<ParticleReader>> open_h5md_reader(const std::filesystem::path& path, const ReaderOptions& options);
Result<std::unique_ptr<ParticleReader>> open_mmpld_reader(const std::filesystem::path& path, const ReaderOptions& options);
Result<std::unique_ptr<ParticleReader>> open_raw_reader(const std::filesystem::path& path, const ReaderOptions& options);

// list_frames() of the text formats.
Result<std::vector<FrameEntry>> list_lammps_frames(const std::filesystem::path& path, const ReaderOptions& options);
Result<std::vector<FrameEntry>> list_xyz_frames(const std::filesystem::path& path, const ReaderOptions& options);

}  // namespace mds
