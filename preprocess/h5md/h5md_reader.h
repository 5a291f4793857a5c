// H5MD reader (HDF5 C API). H5MD: de Buyl, Colberg, Höfling, "H5MD: a structured,
// efficient, and portable file format for molecular data", Comput. Phys. Commun. 185 (2014).
//
// Reads /particles/<group>/position: either a time-dependent element (a group holding
// `value` [frames][N][3], optional `step`) or a time-independent dataset [N][3], float32 or
// float64. The particle group is found by iterating /particles; with several groups that
// have positions, ReaderOptions::h5md_group must name one. Optional species (integer,
// [frames][N] or [N], time-dependent or not) gives type ids (default 1); optional box/edges
// (vector [3] or matrix [3][3], time-dependent or not; optional box/offset) gives the box,
// whose lower corner is 0 unless an offset is stored. ReaderOptions::property names one more
// element of the group, one number per particle ([frames][N] or [N], a trailing [1] allowed,
// integer or floating point). Particles are read in hyperslab batches
// so memory stays bounded.
//
// This folder is the one part of mdstream that links HDF5 (libhdf5 brings 34 more shared
// libraries, 12.7 ms of every process start on the 2-core VM): it is built into the loadable
// module libmdstream_h5md.so (h5md_module_entry.cpp), which the CLI opens only when an input is
// an HDF5 file (readers/h5md_module.h), and into the static library mdstream_h5md for tests.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "readers/reader.h"

namespace mds {

// True when `path` is an HDF5 file that has a /h5md group; false for an HDF5 file without
// it; an error when the file cannot be opened as HDF5.
Result<bool> hdf5_has_h5md_group(const std::filesystem::path& path);

class H5mdReader final : public ParticleReader {
 public:
  static Result<std::unique_ptr<ParticleReader>> open(const std::filesystem::path& path, const ReaderOptions& options);
  ~H5mdReader() override;

  const FrameInfo& info() const override { return info_; }
  Result<size_t> read(ParticleBatch& out, size_t max_particles) override;

  const std::string& group() const { return group_; }
  uint64_t frame_count() const { return frames_; }
  uint64_t frame_index() const { return frame_; }

 private:
  H5mdReader() = default;
  struct Handles;

  std::string file_name_;
  std::string group_;              // /particles/<name>
  std::string position_name_;      // dataset path used in messages
  std::string species_name_;
  std::string property_name_;      // ReaderOptions::property's dataset path, or empty
  std::unique_ptr<Handles> h_;
  bool position_time_dependent_ = true;
  bool species_time_dependent_ = false;
  bool has_species_ = false;
  bool has_property_ = false;
  bool property_time_dependent_ = false;
  uint64_t frames_ = 1;
  uint64_t frame_ = 0;
  uint64_t next_ = 0;
  FrameInfo info_;
  std::vector<double> buffer_;
  std::vector<float> buffer_f32_;
  std::vector<int64_t> species_buffer_;
  std::vector<double> property_buffer_;
};

}  // namespace mds
