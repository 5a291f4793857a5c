// Temporary spill files (see spill.h): POSIX descriptors, buffered record I/O.
#include "convert/spill.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <system_error>

namespace mds::convert {

namespace {

std::atomic<uint64_t> g_tempdir_counter{0};

Status write_all(int fd, const void* data, size_t bytes, const std::filesystem::path& path) {
  const char* p = static_cast<const char*>(data);
  while (bytes > 0) {
    ssize_t w = ::write(fd, p, bytes);
    if (w < 0) {
      if (errno == EINTR) continue;
      return make_error(Errc::io, "{}: write of temporary file failed: {}", path.string(), std::strerror(errno));
    }
    p += w;
    bytes -= size_t(w);
  }
  return {};
}

}  // namespace

TempDir::~TempDir() {
  if (!dir_.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
}

Result<std::filesystem::path> TempDir::file(const std::string& name) {
  if (dir_.empty()) {
    std::error_code ec;
    std::filesystem::path parent = parent_.empty() ? std::filesystem::path(".") : parent_;
    for (int attempt = 0; attempt < 100; ++attempt) {
      std::filesystem::path d =
          parent / fmt::format(".mdstream-tmp-{}-{}", ::getpid(), g_tempdir_counter.fetch_add(1));
      if (::mkdir(d.c_str(), 0700) == 0) {
        dir_ = d;
        break;
      }
      if (errno != EEXIST)
        return make_error(Errc::io, "{}: cannot create temporary directory: {}", d.string(), std::strerror(errno));
    }
    if (dir_.empty()) return make_error(Errc::io, "{}: cannot create a temporary directory", parent.string());
  }
  return dir_ / name;
}

template <class T>
SpillWriterOf<T>::~SpillWriterOf() {
  if (fd_ >= 0) ::close(fd_);
}

template <class T>
SpillWriterOf<T>::SpillWriterOf(SpillWriterOf&& o) noexcept { *this = std::move(o); }

template <class T>
SpillWriterOf<T>& SpillWriterOf<T>::operator=(SpillWriterOf&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    o.fd_ = -1;
    path_ = std::move(o.path_);
    buf_ = std::move(o.buf_);
    cap_ = o.cap_;
    count_ = o.count_;
  }
  return *this;
}

template <class T>
Result<SpillWriterOf<T>> SpillWriterOf<T>::create(const std::filesystem::path& path, size_t buffer_bytes) {
  SpillWriterOf w;
  w.fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (w.fd_ < 0) return make_error(Errc::io, "{}: cannot create temporary file: {}", path.string(), std::strerror(errno));
  w.path_ = path;
  w.cap_ = std::max<size_t>(1, buffer_bytes / sizeof(T));
  w.buf_.reserve(w.cap_);
  return w;
}

template <class T>
Status SpillWriterOf<T>::append(std::span<const T> rs) {
  for (const auto& r : rs) MDS_TRY(append(r));
  return {};
}

template <class T>
Status SpillWriterOf<T>::flush() {
  if (buf_.empty()) return {};
  MDS_TRY(write_all(fd_, buf_.data(), buf_.size() * sizeof(T), path_));
  buf_.clear();
  return {};
}

template <class T>
Status SpillWriterOf<T>::close() {
  if (fd_ < 0) return {};
  MDS_TRY(flush());
  int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) return make_error(Errc::io, "{}: close failed: {}", path_.string(), std::strerror(errno));
  buf_ = {};
  return {};
}

template <class T>
SpillReaderOf<T>::~SpillReaderOf() {
  if (fd_ >= 0) ::close(fd_);
}

template <class T>
SpillReaderOf<T>::SpillReaderOf(SpillReaderOf&& o) noexcept { *this = std::move(o); }

template <class T>
SpillReaderOf<T>& SpillReaderOf<T>::operator=(SpillReaderOf&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    o.fd_ = -1;
    path_ = std::move(o.path_);
    count_ = o.count_;
    offset_ = o.offset_;
  }
  return *this;
}

template <class T>
Result<SpillReaderOf<T>> SpillReaderOf<T>::open(const std::filesystem::path& path) {
  SpillReaderOf r;
  r.fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (r.fd_ < 0) return make_error(Errc::io, "{}: cannot open temporary file: {}", path.string(), std::strerror(errno));
  r.path_ = path;
  struct stat st {};
  if (::fstat(r.fd_, &st) != 0) return make_error(Errc::io, "{}: stat failed: {}", path.string(), std::strerror(errno));
  if (uint64_t(st.st_size) % sizeof(T) != 0)
    return make_error(Errc::internal, "{}: temporary file size {} is not a multiple of {}", path.string(),
                      uint64_t(st.st_size), sizeof(T));
  r.count_ = uint64_t(st.st_size) / sizeof(T);
#ifdef POSIX_FADV_SEQUENTIAL
  ::posix_fadvise(r.fd_, 0, 0, POSIX_FADV_SEQUENTIAL);
#endif
  return r;
}

template <class T>
Result<size_t> SpillReaderOf<T>::read(std::span<T> out) {
  char* p = reinterpret_cast<char*>(out.data());
  size_t want = out.size() * sizeof(T);
  size_t got = 0;
  while (got < want) {
    ssize_t n = ::read(fd_, p + got, want - got);
    if (n < 0) {
      if (errno == EINTR) continue;
      return make_error(Errc::io, "{}: read of temporary file failed at byte {}: {}", path_.string(), offset_ + got,
                        std::strerror(errno));
    }
    if (n == 0) break;
    got += size_t(n);
  }
  if (got % sizeof(T) != 0)
    return make_error(Errc::io, "{}: temporary file truncated at byte {}", path_.string(), offset_ + got);
  offset_ += got;
  return got / sizeof(T);
}

template class SpillWriterOf<SpillRecord>;
template class SpillReaderOf<SpillRecord>;
template class SpillWriterOf<uint32_t>;
template class SpillReaderOf<uint32_t>;

}  // namespace mds::convert
