// File I/O helpers: RAII fd, pread/pwrite loops, buffered writes, temp file + fsync + rename.
#include "store/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

namespace mds::store {

namespace {
std::string errno_text(int e) { return std::strerror(e); }
}  // namespace

File::~File() {
  if (fd_ >= 0) ::close(fd_);
}

File::File(File&& o) noexcept : fd_(o.fd_), path_(std::move(o.path_)) { o.fd_ = -1; }

File& File::operator=(File&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.fd_;
    path_ = std::move(o.path_);
    o.fd_ = -1;
  }
  return *this;
}

Result<File> File::open_read(const std::filesystem::path& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return make_error(Errc::io, "{}: cannot open for reading: {}", path.string(), errno_text(errno));
  struct stat st{};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return make_error(Errc::io, "{}: not a regular file", path.string());
  }
  File f;
  f.fd_ = fd;
  f.path_ = path;
  return f;
}

Result<File> File::create(const std::filesystem::path& path) {
  int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return make_error(Errc::io, "{}: cannot create: {}", path.string(), errno_text(errno));
  File f;
  f.fd_ = fd;
  f.path_ = path;
  return f;
}

Result<uint64_t> File::size() const {
  struct stat st{};
  if (::fstat(fd_, &st) != 0) return make_error(Errc::io, "{}: fstat failed: {}", path_.string(), errno_text(errno));
  return static_cast<uint64_t>(st.st_size);
}

Status File::pread_all(void* dst, size_t n, uint64_t offset) const {
  auto* p = static_cast<uint8_t*>(dst);
  size_t done = 0;
  while (done < n) {
    ssize_t r = ::pread(fd_, p + done, n - done, static_cast<off_t>(offset + done));
    if (r < 0) {
      if (errno == EINTR) continue;
      return make_error(Errc::io, "{}: read of {} bytes at byte {} failed: {}", path_.string(), n, offset,
                        errno_text(errno));
    }
    if (r == 0)
      return make_error(Errc::range, "{}: file ends at byte {}, expected {} bytes at byte {}", path_.string(),
                        offset + done, n, offset);
    done += static_cast<size_t>(r);
  }
  return {};
}

Status File::pwrite_all(const void* src, size_t n, uint64_t offset) {
  const auto* p = static_cast<const uint8_t*>(src);
  size_t done = 0;
  while (done < n) {
    ssize_t r = ::pwrite(fd_, p + done, n - done, static_cast<off_t>(offset + done));
    if (r < 0) {
      if (errno == EINTR) continue;
      return make_error(Errc::io, "{}: write at byte {} failed: {}", path_.string(), offset + done, errno_text(errno));
    }
    done += static_cast<size_t>(r);
  }
  return {};
}

Status File::write_all(const void* src, size_t n) {
  const auto* p = static_cast<const uint8_t*>(src);
  size_t done = 0;
  while (done < n) {
    ssize_t r = ::write(fd_, p + done, n - done);
    if (r < 0) {
      if (errno == EINTR) continue;
      return make_error(Errc::io, "{}: write failed: {}", path_.string(), errno_text(errno));
    }
    done += static_cast<size_t>(r);
  }
  return {};
}

Status File::sync() {
  if (::fsync(fd_) != 0) return make_error(Errc::io, "{}: fsync failed: {}", path_.string(), errno_text(errno));
  return {};
}

Status File::close() {
  if (fd_ < 0) return {};
  int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) return make_error(Errc::io, "{}: close failed: {}", path_.string(), errno_text(errno));
  return {};
}

BufferedWriter::BufferedWriter(File& file, size_t buffer_bytes, uint64_t start_offset)
    : file_(file), buf_(buffer_bytes), offset_(start_offset) {}

Status BufferedWriter::write(const void* src, size_t n) {
  const auto* p = static_cast<const uint8_t*>(src);
  if (used_ + n > buf_.size()) {
    MDS_TRY(flush());
    if (n >= buf_.size()) {
      MDS_TRY(file_.write_all(p, n));
      offset_ += n;
      return {};
    }
  }
  if (n > 0) std::memcpy(buf_.data() + used_, p, n);
  used_ += n;
  offset_ += n;
  return {};
}

Status BufferedWriter::flush() {
  if (used_ == 0) return {};
  size_t n = used_;
  used_ = 0;
  return file_.write_all(buf_.data(), n);
}

std::filesystem::path temp_path_for(const std::filesystem::path& path) {
  std::filesystem::path t = path;
  t += ".tmp." + std::to_string(::getpid());
  return t;
}

Result<AtomicOutput> AtomicOutput::create(const std::filesystem::path& path) {
  AtomicOutput out;
  out.final_ = path;
  out.temp_ = temp_path_for(path);
  MDS_ASSIGN_OR_RETURN(out.file_, File::create(out.temp_));
  out.active_ = true;
  return out;
}

AtomicOutput::~AtomicOutput() { abandon(); }

AtomicOutput::AtomicOutput(AtomicOutput&& o) noexcept
    : file_(std::move(o.file_)), final_(std::move(o.final_)), temp_(std::move(o.temp_)), active_(o.active_) {
  o.active_ = false;
}

AtomicOutput& AtomicOutput::operator=(AtomicOutput&& o) noexcept {
  if (this != &o) {
    abandon();
    file_ = std::move(o.file_);
    final_ = std::move(o.final_);
    temp_ = std::move(o.temp_);
    active_ = o.active_;
    o.active_ = false;
  }
  return *this;
}

void AtomicOutput::abandon() {
  if (!active_) return;
  active_ = false;
  (void)file_.close();
  std::error_code ec;
  std::filesystem::remove(temp_, ec);
}

Status AtomicOutput::commit() {
  if (!active_) return make_error(Errc::internal, "{}: output already committed or abandoned", final_.string());
  MDS_TRY(file_.sync());
  MDS_TRY(file_.close());
  std::error_code ec;
  std::filesystem::rename(temp_, final_, ec);
  if (ec) {
    Error e = make_error(Errc::io, "{}: cannot rename {} into place: {}", final_.string(), temp_.string(), ec.message());
    abandon();
    return e;
  }
  active_ = false;
  // Make the rename durable.
  std::filesystem::path dir = final_.parent_path();
  if (dir.empty()) dir = ".";
  int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return {};
}

}  // namespace mds::store
