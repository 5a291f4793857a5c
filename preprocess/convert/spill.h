// Temporary particle spill files of the out-of-core converter: fixed 32-byte records,
// written and read through large buffers. Every temporary file lives inside a TempDir,
// which removes itself (and everything in it) when destroyed, on success and on error.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"

namespace mds::convert {

struct SpillRecord {
  double x, y, z;
  int32_t type;   // input type id
  float radius;   // per-particle radius, or the type's radius
};
static_assert(sizeof(SpillRecord) == 32);

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

// Append-only file of records with a write buffer. Owns its descriptor.
class SpillWriter {
 public:
  SpillWriter() = default;
  ~SpillWriter();
  SpillWriter(SpillWriter&& o) noexcept;
  SpillWriter& operator=(SpillWriter&& o) noexcept;
  SpillWriter(const SpillWriter&) = delete;
  SpillWriter& operator=(const SpillWriter&) = delete;

  static Result<SpillWriter> create(const std::filesystem::path& path, size_t buffer_bytes);
  Status append(const SpillRecord& r) {
    if (buf_.size() == cap_) MDS_TRY(flush());
    buf_.push_back(r);
    ++count_;
    return {};
  }
  Status append(std::span<const SpillRecord> rs);
  Status flush();
  // Flushes and closes; the file stays on disk.
  Status close();
  uint64_t count() const { return count_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  int fd_ = -1;
  std::filesystem::path path_;
  std::vector<SpillRecord> buf_;
  size_t cap_ = 0;
  uint64_t count_ = 0;
};

// Reads a spill file sequentially in chunks.
class SpillReader {
 public:
  SpillReader() = default;
  ~SpillReader();
  SpillReader(SpillReader&& o) noexcept;
  SpillReader& operator=(SpillReader&& o) noexcept;
  SpillReader(const SpillReader&) = delete;
  SpillReader& operator=(const SpillReader&) = delete;

  static Result<SpillReader> open(const std::filesystem::path& path);
  // Reads up to out.size() records; returns how many (0 at the end).
  Result<size_t> read(std::span<SpillRecord> out);
  uint64_t count() const { return count_; }

 private:
  int fd_ = -1;
  std::filesystem::path path_;
  uint64_t count_ = 0;
  uint64_t offset_ = 0;
};

}  // namespace mds::convert
