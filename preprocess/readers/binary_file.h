// Read-only binary file with positional reads (pread), RAII-closed. Used by the
// binary readers (MMPLD, raw) so that every read is bounds-checked against the
// file size and every error names the file and the byte offset.
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

}  // namespace mds
