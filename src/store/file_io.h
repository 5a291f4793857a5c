// File I/O helpers shared by the store writer, the store reader and CLI commands that write
// files: an RAII file descriptor with full-length positioned reads/writes, a buffered
// sequential writer, and AtomicOutput (write "<path>.tmp.<pid>", fsync, rename; the temporary
// file is removed when the output is abandoned). Errors name the file and the byte offset.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

#include "core/result.h"

namespace mds::store {

class File {
 public:
  File() = default;
  ~File();
  File(File&& o) noexcept;
  File& operator=(File&& o) noexcept;
  File(const File&) = delete;
  File& operator=(const File&) = delete;

  static Result<File> open_read(const std::filesystem::path& path);
  // Creates (or truncates) a file for writing, mode 0644.
  static Result<File> create(const std::filesystem::path& path);

  bool is_open() const { return fd_ >= 0; }
  const std::filesystem::path& path() const { return path_; }
  Result<uint64_t> size() const;

  // Reads exactly `n` bytes at `offset`; a short read is Errc::range ("file ends at byte ...").
  // Thread-safe (pread).
  Status pread_all(void* dst, size_t n, uint64_t offset) const;
  Status pwrite_all(const void* src, size_t n, uint64_t offset);
  Status write_all(const void* src, size_t n);
  Status sync();
  Status close();

 private:
  int fd_ = -1;
  std::filesystem::path path_;
};

// Sequential writer with a large buffer; tracks the current file offset.
class BufferedWriter {
 public:
  explicit BufferedWriter(File& file, size_t buffer_bytes = 8u << 20, uint64_t start_offset = 0);
  Status write(const void* src, size_t n);
  Status write(std::span<const uint8_t> bytes) { return write(bytes.data(), bytes.size()); }
  Status flush();
  uint64_t offset() const { return offset_; }

 private:
  File& file_;
  std::vector<uint8_t> buf_;
  size_t used_ = 0;
  uint64_t offset_ = 0;
};

// "<path>.tmp.<pid>" in the same directory as `path`.
std::filesystem::path temp_path_for(const std::filesystem::path& path);

// An output file that appears at its final path only on commit().
class AtomicOutput {
 public:
  static Result<AtomicOutput> create(const std::filesystem::path& path);
  AtomicOutput() = default;
  ~AtomicOutput();
  AtomicOutput(AtomicOutput&& o) noexcept;
  AtomicOutput& operator=(AtomicOutput&& o) noexcept;
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  File& file() { return file_; }
  const std::filesystem::path& final_path() const { return final_; }
  const std::filesystem::path& temp_path() const { return temp_; }
  // fsync, close, rename over the final path, fsync the directory.
  Status commit();
  // Closes and removes the temporary file (also done by the destructor unless committed).
  void abandon();

 private:
  File file_;
  std::filesystem::path final_;
  std::filesystem::path temp_;
  bool active_ = false;
};

}  // namespace mds::store
