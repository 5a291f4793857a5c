// Temporary particle spill files of the out-of-core converter: fixed 32-byte records, and with
// a per-particle property (`convert --property`) or colour (`convert --color`) a parallel side
// column of 4-byte words (SideLayout), both written and read through large buffers. Every temporary file lives inside a TempDir,
// which removes itself (and everything in it) when destroyed, on success and on error.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"

namespace mds::convert {

// The property and the colour are not in the record: they are a side column of their own (4
// bytes a particle for each that is asked for), so that a conversion without them moves 32 bytes
// a particle, not 40 (a 10M-particle LAMMPS text conversion took 1.15x the time with 40-byte
// records on the 2-core VM).
struct SpillRecord {
  double x, y, z;
  int32_t type;   // input type id
  float radius;   // per-particle radius, or the type's radius
};
static_assert(sizeof(SpillRecord) == 32);

// The side column's words per record, in this order: the property's float bits (`--property`),
// then the RGBA8 colour (`--color`, readers/reader.h pack_rgba8). 0, 4 or 8 bytes a particle.
struct SideLayout {
  bool property = false;
  bool color = false;
  uint32_t words() const { return uint32_t(property) + uint32_t(color); }
  uint32_t property_word() const { return 0; }
  uint32_t color_word() const { return property ? 1 : 0; }
};

// A uniquely named directory, created lazily on first use; removed recursively on destruction.
class TempDir {
 public:
  explicit TempDir(std::filesystem::path parent) : parent_(std::move(parent)) {}
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  // Creates the directory if needed and returns parent/.mdstream-tmp-<pid>-<n>/name.
  Result<std::filesystem::path> file(const std::string& name);
  bool created() const { return !dir_.empty(); }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path parent_;
  std::filesystem::path dir_;
};

// Append-only file of records (T = SpillRecord, or uint32_t for the side column) with a
// write buffer. Owns its descriptor.
template <class T>
class SpillWriterOf {
 public:
  SpillWriterOf() = default;
  ~SpillWriterOf();
  SpillWriterOf(SpillWriterOf&& o) noexcept;
  SpillWriterOf& operator=(SpillWriterOf&& o) noexcept;
  SpillWriterOf(const SpillWriterOf&) = delete;
  SpillWriterOf& operator=(const SpillWriterOf&) = delete;

  static Result<SpillWriterOf> create(const std::filesystem::path& path, size_t buffer_bytes);
  Status append(const T& r) {
    if (buf_.size() == cap_) MDS_TRY(flush());
    buf_.push_back(r);
    ++count_;
    return {};
  }
  Status append(std::span<const T> rs);
  Status flush();
  // Flushes and closes; the file stays on disk.
  Status close();
  uint64_t count() const { return count_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  int fd_ = -1;
  std::filesystem::path path_;
  std::vector<T> buf_;
  size_t cap_ = 0;
  uint64_t count_ = 0;
};

// Reads a spill file of T sequentially in chunks.
template <class T>
class SpillReaderOf {
 public:
  SpillReaderOf() = default;
  ~SpillReaderOf();
  SpillReaderOf(SpillReaderOf&& o) noexcept;
  SpillReaderOf& operator=(SpillReaderOf&& o) noexcept;
  SpillReaderOf(const SpillReaderOf&) = delete;
  SpillReaderOf& operator=(const SpillReaderOf&) = delete;

  static Result<SpillReaderOf> open(const std::filesystem::path& path);
  // Reads up to out.size() records; returns how many (0 at the end).
  Result<size_t> read(std::span<T> out);
  uint64_t count() const { return count_; }

 private:
  int fd_ = -1;
  std::filesystem::path path_;
  uint64_t count_ = 0;
  uint64_t offset_ = 0;
};

// Instantiated in spill.cpp for these two.
using SpillWriter = SpillWriterOf<SpillRecord>;
using SpillReader = SpillReaderOf<SpillRecord>;
using SideSpillWriter = SpillWriterOf<uint32_t>;
using SideSpillReader = SpillReaderOf<uint32_t>;

}  // namespace mds::convert
