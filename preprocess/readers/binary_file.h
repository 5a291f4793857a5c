// Read-only binary file with positional reads (pread), RAII-closed. Used by the
// binary readers (MMPLD, raw) so that every read is bounds-checked against the
// file size and every error names the file and the byte offset. FileMapping maps a
// whole file read-only (the raw reader's bulk path for the converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "core/result.h"

namespace mds {

class BinaryFile {
 public:
  static Result<BinaryFile> open(const std::filesystem::path& path);

  BinaryFile(BinaryFile&& o) noexcept;
  BinaryFile& operator=(BinaryFile&& o) noexcept;
  BinaryFile(const BinaryFile&) = delete;
  BinaryFile& operator=(const BinaryFile&) = delete;
  ~BinaryFile();

  uint64_t size() const { return size_; }
  const std::string& name() const { return name_; }

  // Reads exactly `n` bytes at `offset`; an error naming `what` and the offset when the
  // range lies (partly) outside the file or the read fails.
  Status read_at(uint64_t offset, void* dst, size_t n, const char* what) const;

  int fd() const { return fd_; }

  template <class T>
  Result<T> read_pod(uint64_t offset, const char* what) const {
    T v{};
    MDS_TRY(read_at(offset, &v, sizeof(T), what));
    return v;
  }

 private:
  BinaryFile(int fd, uint64_t size, std::string name) : fd_(fd), size_(size), name_(std::move(name)) {}
  int fd_ = -1;
  uint64_t size_ = 0;
  std::string name_;
};

// A read-only, private mapping of a whole file; unmapped on destruction.
class FileMapping {
 public:
  FileMapping() = default;
  static Result<FileMapping> map(const BinaryFile& file);
  FileMapping(FileMapping&& o) noexcept;
  FileMapping& operator=(FileMapping&& o) noexcept;
  FileMapping(const FileMapping&) = delete;
  FileMapping& operator=(const FileMapping&) = delete;
  ~FileMapping();

  const void* data() const { return data_; }
  uint64_t size() const { return size_; }

 private:
  void* data_ = nullptr;
  uint64_t size_ = 0;
};

}  // namespace mds
