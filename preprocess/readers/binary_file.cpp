#include "readers/binary_file.h"

#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

namespace mds {

Result<BinaryFile> BinaryFile::open(const std::filesystem::path& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return make_error(Errc::io, "{}: cannot open: {}", path.string(), std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return make_error(Errc::io, "{}: not a regular file", path.string());
  }
  return BinaryFile(fd, static_cast<uint64_t>(st.st_size), path.string());
}

BinaryFile::BinaryFile(BinaryFile&& o) noexcept : fd_(o.fd_), size_(o.size_), name_(std::move(o.name_)) { o.fd_ = -1; }

BinaryFile& BinaryFile::operator=(BinaryFile&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    size_ = o.size_;
    name_ = std::move(o.name_);
    o.fd_ = -1;
  }
  return *this;
}

BinaryFile::~BinaryFile() {
  if (fd_ >= 0) ::close(fd_);
}

Status BinaryFile::read_at(uint64_t offset, void* dst, size_t n, const char* what) const {
  if (offset > size_ || n > size_ - offset) {
    return make_error(Errc::format, "{}: byte offset {}: {} ({} bytes) runs past the end of the file ({} bytes)",
                      name_, offset, what, n, size_);
  }
  auto* p = static_cast<char*>(dst);
  size_t done = 0;
  while (done < n) {
    ssize_t r = ::pread(fd_, p + done, n - done, static_cast<off_t>(offset + done));
    if (r < 0) {
      if (errno == EINTR) continue;
      return make_error(Errc::io, "{}: byte offset {}: read failed: {}", name_, offset + done, std::strerror(errno));
    }
    if (r == 0) {
      return make_error(Errc::format, "{}: byte offset {}: unexpected end of file reading {}", name_, offset + done, what);
    }
    done += static_cast<size_t>(r);
  }
  return Status::success();
}

Result<FileMapping> FileMapping::map(const BinaryFile& file) {
  FileMapping m;
  if (file.size() == 0) return m;
  void* p = ::mmap(nullptr, static_cast<size_t>(file.size()), PROT_READ, MAP_PRIVATE, file.fd(), 0);
  if (p == MAP_FAILED) return make_error(Errc::io, "{}: cannot map the file: {}", file.name(), std::strerror(errno));
  (void)::madvise(p, static_cast<size_t>(file.size()), MADV_SEQUENTIAL);
  m.data_ = p;
  m.size_ = file.size();
  return m;
}

FileMapping::FileMapping(FileMapping&& o) noexcept : data_(o.data_), size_(o.size_) {
  o.data_ = nullptr;
  o.size_ = 0;
}

FileMapping& FileMapping::operator=(FileMapping&& o) noexcept {
  if (this != &o) {
    if (data_) ::munmap(data_, static_cast<size_t>(size_));
    data_ = o.data_;
    size_ = o.size_;
    o.data_ = nullptr;
    o.size_ = 0;
  }
  return *this;
}

FileMapping::~FileMapping() {
  if (data_) ::munmap(data_, static_cast<size_t>(size_));
}

}  // namespace mds
