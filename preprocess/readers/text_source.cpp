// Buffered line source over plain, gzip and zstd files (see text_source.h).
#include "readers/text_source.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <thread>

#include <zlib.h>
#include <zstd.h>

#include "core/huge_pages.h"

namespace mds {

namespace {

constexpr size_t kMaxLineBytes = size_t{16} << 20;

// RAII file descriptor.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() { reset(); }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  void reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

Result<int> open_fd(const std::filesystem::path& path, const std::string& name) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return make_error(Errc::io, "{}: cannot open: {}", name, std::strerror(errno));
  return fd;
}

// Reads up to n bytes, retrying on EINTR and short reads; returns 0 only at the end.
Result<size_t> read_fd(int fd, char* dst, size_t n, const std::string& name) {
  size_t got = 0;
  while (got < n) {
    ssize_t r = ::read(fd, dst + got, n - got);
    if (r < 0) {
      if (errno == EINTR) continue;
      return make_error(Errc::io, "{}: read failed: {}", name, std::strerror(errno));
    }
    if (r == 0) break;
    got += static_cast<size_t>(r);
  }
  return got;
}

}  // namespace

// Raw byte input. read() returns the bytes it could produce; an error found after some
// bytes were produced (a truncated compressed stream) is returned by the next call, so
// that the lines before it are still seen and the message can name the line.
class TextSource::Input {
 public:
  virtual ~Input() = default;
  virtual Result<size_t> read(char* dst, size_t n) = 0;
  // Plain files only: position at an absolute offset.
  virtual bool seek(uint64_t) { return false; }
};

namespace {

class PlainInput final : public TextSource::Input {
 public:
  PlainInput(int fd, std::string name) : fd_(fd), name_(std::move(name)) {
#ifdef POSIX_FADV_SEQUENTIAL
    ::posix_fadvise(fd_.get(), 0, 0, POSIX_FADV_SEQUENTIAL);
#endif
  }
  Result<size_t> read(char* dst, size_t n) override { return read_fd(fd_.get(), dst, n, name_); }
  bool seek(uint64_t off) override {
    return ::lseek(fd_.get(), static_cast<off_t>(off), SEEK_SET) == static_cast<off_t>(off);
  }

 private:
  Fd fd_;
  std::string name_;
};

class GzipInput final : public TextSource::Input {
 public:
  GzipInput(gzFile f, std::string name) : f_(f), name_(std::move(name)) { gzbuffer(f_, 1u << 20); }
  ~GzipInput() override { gzclose(f_); }
  Result<size_t> read(char* dst, size_t n) override {
    if (pending_) return *pending_;
    size_t got = 0;
    while (got < n) {
      unsigned chunk = static_cast<unsigned>(std::min<size_t>(n - got, 1u << 30));
      int r = gzread(f_, dst + got, chunk);
      int errnum = Z_OK;
      const char* msg = gzerror(f_, &errnum);
      if (r < 0 || (errnum != Z_OK && errnum != Z_STREAM_END)) {
        Error e = errnum == Z_BUF_ERROR
                      ? make_error(Errc::format, "{}: gzip stream ends early (file truncated?)", name_)
                      : make_error(Errc::format, "{}: gzip decompression failed: {}", name_, msg ? msg : "?");
        if (r > 0) got += static_cast<size_t>(r);
        if (got == 0) return e;
        pending_ = e;
        return got;
      }
      if (r == 0) break;
      got += static_cast<size_t>(r);
    }
    return got;
  }

 private:
  gzFile f_;
  std::string name_;
  std::optional<Error> pending_;
};

class ZstdInput final : public TextSource::Input {
 public:
  ZstdInput(int fd, std::string name)
      : fd_(fd), name_(std::move(name)), dctx_(ZSTD_createDCtx()), in_buf_(ZSTD_DStreamInSize()) {}
  ~ZstdInput() override { ZSTD_freeDCtx(dctx_); }
  Result<size_t> read(char* dst, size_t n) override {
    if (pending_) return *pending_;
    ZSTD_outBuffer out{dst, n, 0};
    while (out.pos < out.size) {
      if (in_.pos == in_.size && !in_eof_) {
        MDS_ASSIGN_OR_RETURN(size_t r, read_fd(fd_.get(), in_buf_.data(), in_buf_.size(), name_));
        compressed_read_ += r;
        if (r == 0) in_eof_ = true;
        in_ = ZSTD_inBuffer{in_buf_.data(), r, 0};
      }
      size_t before_out = out.pos, before_in = in_.pos;
      size_t ret = ZSTD_decompressStream(dctx_, &out, &in_);
      if (ZSTD_isError(ret)) {
        Error e = make_error(Errc::format, "{}: zstd decompression failed near compressed byte {}: {}",
                             name_, compressed_read_ - (in_.size - in_.pos), ZSTD_getErrorName(ret));
        if (out.pos == 0) return e;
        pending_ = e;
        return out.pos;
      }
      if (in_eof_ && in_.pos == in_.size && out.pos == before_out && in_.pos == before_in) {
        // No progress with all input consumed: complete only if the last frame ended.
        if (last_ret_ != 0) {
          Error e = make_error(Errc::format, "{}: zstd stream ends early (file truncated?)", name_);
          if (out.pos == 0) return e;
          pending_ = e;
        }
        break;
      }
      last_ret_ = ret;  // 0 when a frame was completely decoded and flushed
    }
    return out.pos;
  }

 private:
  Fd fd_;
  std::string name_;
  ZSTD_DCtx* dctx_;
  std::vector<char> in_buf_;
  ZSTD_inBuffer in_{nullptr, 0, 0};
  bool in_eof_ = false;
  size_t last_ret_ = 0;
  uint64_t compressed_read_ = 0;
  std::optional<Error> pending_;
};

// Runs a compressed input on a worker thread, a few chunks ahead of the consumer, so that
// decompression overlaps parsing.
class PrefetchInput final : public TextSource::Input {
 public:
  PrefetchInput(std::unique_ptr<TextSource::Input> inner, size_t chunk_bytes)
      : inner_(std::move(inner)), chunk_bytes_(std::clamp<size_t>(chunk_bytes, 4096, kMaxChunkBytes)) {
    worker_ = std::thread([this] { run(); });
  }
  ~PrefetchInput() override {
    {
      std::lock_guard<std::mutex> lk(m_);
      stop_ = true;
    }
    cv_.notify_all();
    worker_.join();
  }
  Result<size_t> read(char* dst, size_t n) override {
    std::unique_lock<std::mutex> lk(m_);
    size_t got = 0;
    while (got < n) {
      if (ready_.empty()) {
        if (got > 0) break;  // hand out what we have rather than wait
        cv_.wait(lk, [&] { return !ready_.empty(); });
      }
      Chunk& c = ready_.front();
      if (c.error) {
        if (got > 0) break;
        return *c.error;   // stays queued: later calls repeat it
      }
      if (c.size == 0) break;  // end of input (stays queued)
      size_t k = std::min(n - got, c.size - c.pos);
      std::memcpy(dst + got, c.data.data() + c.pos, k);
      c.pos += k;
      got += k;
      if (c.pos == c.size) {
        free_.push_back(std::move(c.data));
        ready_.pop_front();
        cv_.notify_all();
      }
    }
    return got;
  }

 private:
  struct Chunk {
    std::vector<char> data;
    size_t size = 0, pos = 0;
    std::optional<Error> error;
  };
  static constexpr size_t kMaxChunkBytes = size_t{4} << 20;
  static constexpr size_t kDepth = 3;

  void run() {
    while (true) {
      std::vector<char> buf;
      {
        std::unique_lock<std::mutex> lk(m_);
        cv_.wait(lk, [&] { return stop_ || ready_.size() < kDepth; });
        if (stop_) return;
        if (!free_.empty()) {
          buf = std::move(free_.back());
          free_.pop_back();
        }
      }
      buf.resize(chunk_bytes_);
      auto r = inner_->read(buf.data(), buf.size());
      Chunk c;
      bool last = false;
      if (!r.ok()) {
        c.error = r.error();
        last = true;
      } else {
        c.size = *r;
        last = c.size == 0;
        c.data = std::move(buf);
      }
      {
        std::lock_guard<std::mutex> lk(m_);
        ready_.push_back(std::move(c));
      }
      cv_.notify_all();
      if (last) return;
    }
  }

  std::unique_ptr<TextSource::Input> inner_;
  const size_t chunk_bytes_;
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<Chunk> ready_;
  std::vector<std::vector<char>> free_;
  bool stop_ = false;
  std::thread worker_;
};

// Pointer one past the k-th '\n' in [b, e); k >= 1 and there must be at least k newlines.
const char* after_nth_newline(const char* b, const char* e, size_t k) {
  constexpr size_t kChunk = 64 * 1024;
  while (b < e) {
    const char* ce = std::min(e, b + kChunk);
    size_t c = count_newlines(b, ce);
    if (c >= k) break;
    k -= c;
    b = ce;
  }
  while (true) {
    const char* nl = static_cast<const char*>(std::memchr(b, '\n', static_cast<size_t>(e - b)));
    if (--k == 0) return nl + 1;
    b = nl + 1;
  }
}

// Pointer one past the k-th '\n' in [b, e) (k >= 1), or e when [b, e) holds fewer; `found` is
// the number of newlines in [b, result). Counts only as far as it needs to.
const char* after_up_to_n_newlines(const char* b, const char* e, size_t k, size_t& found) {
  constexpr size_t kChunk = 64 * 1024;
  found = 0;
  while (b < e) {
    const char* ce = std::min(e, b + kChunk);
    const size_t c = count_newlines(b, ce);
    if (found + c >= k) {
      const char* r = after_nth_newline(b, ce, k - found);
      found = k;
      return r;
    }
    found += c;
    b = ce;
  }
  return e;
}

}  // namespace

TextSource::~TextSource() = default;

Result<std::unique_ptr<TextSource>> TextSource::open(const std::filesystem::path& path, size_t buffer_bytes) {
  std::unique_ptr<TextSource> s(new TextSource());
  s->path_ = path;
  s->name_ = path.string();
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    return make_error(Errc::io, "{}: cannot open: {}", s->name_, std::strerror(errno));
  if (!S_ISREG(st.st_mode)) return make_error(Errc::io, "{}: not a regular file", s->name_);
  s->file_size_ = static_cast<uint64_t>(st.st_size);

  unsigned char magic[6] = {0, 0, 0, 0, 0, 0};
  {
    MDS_ASSIGN_OR_RETURN(int raw, open_fd(path, s->name_));
    Fd fd(raw);
    MDS_ASSIGN_OR_RETURN(size_t got, read_fd(fd.get(), reinterpret_cast<char*>(magic), sizeof magic, s->name_));
    (void)got;
  }
  if (magic[0] == 0x1f && magic[1] == 0x8b) {
    s->compression_ = TextCompression::gzip;
  } else if (magic[0] == 0x28 && magic[1] == 0xb5 && magic[2] == 0x2f && magic[3] == 0xfd) {
    s->compression_ = TextCompression::zstd;
  } else if (magic[0] == 0xfd && magic[1] == '7' && magic[2] == 'z' && magic[3] == 'X' && magic[4] == 'Z') {
    return make_error(Errc::unsupported, "{}: xz-compressed; only gzip and zstd are supported", s->name_);
  } else if (magic[0] == 'B' && magic[1] == 'Z' && magic[2] == 'h') {
    return make_error(Errc::unsupported, "{}: bzip2-compressed; only gzip and zstd are supported", s->name_);
  }
  // Small files get a small buffer (a plain file's lines fit in its size; compressed ones
  // are assumed to expand at most ~8x before the buffer has to grow or refill).
  const uint64_t expect = s->compression_ == TextCompression::none ? s->file_size_ + 1 : s->file_size_ * 8;
  s->cap_ = static_cast<size_t>(std::clamp<uint64_t>(expect, 4096, std::max<size_t>(buffer_bytes, 4096)));
  s->buf_.reset(new char[s->cap_ + 1]);
  // Its first fill otherwise faults the buffer in one 4 KiB page at a time: on the 2-core VM
  // the first 8 MiB read took about 25 ms, most of a 1M-particle dump's setup stage.
  advise_huge_pages(s->buf_.get(), s->cap_);
  MDS_TRY(s->reopen_input());
  return s;
}

Status TextSource::reopen_input() {
  input_.reset();
  if (compression_ == TextCompression::gzip) {
    gzFile f = gzopen(path_.c_str(), "rb");
    if (!f) return make_error(Errc::io, "{}: cannot open: {}", name_, std::strerror(errno));
    input_ = std::make_unique<PrefetchInput>(std::make_unique<GzipInput>(f, name_), cap_ / 2);
  } else {
    MDS_ASSIGN_OR_RETURN(int fd, open_fd(path_, name_));
    if (compression_ == TextCompression::zstd)
      input_ = std::make_unique<PrefetchInput>(std::make_unique<ZstdInput>(fd, name_), cap_ / 2);
    else
      input_ = std::make_unique<PlainInput>(fd, name_);
  }
  pos_ = end_ = 0;
  buf_offset_ = 0;
  line_ = 0;
  eof_ = false;
  return {};
}

std::optional<uint64_t> TextSource::remaining_bytes() const {
  if (compression_ != TextCompression::none) return std::nullopt;
  uint64_t t = tell();
  return t < file_size_ ? file_size_ - t : 0;
}

Status TextSource::fill() {
  if (eof_) return {};
  if (pos_ > 0) {
    std::memmove(buf_.get(), buf_.get() + pos_, end_ - pos_);
    buf_offset_ += pos_;
    end_ -= pos_;
    pos_ = 0;
  }
  if (end_ == cap_) {
    if (cap_ >= kMaxLineBytes)
      return make_error(Errc::format, "{}:{}: line longer than {} MiB (not a text file?)", name_, line_ + 1,
                        kMaxLineBytes >> 20);
    size_t ncap = std::min(cap_ * 2, kMaxLineBytes);
    std::unique_ptr<char[]> nb(new char[ncap + 1]);
    advise_huge_pages(nb.get(), ncap);
    std::memcpy(nb.get(), buf_.get(), end_);
    buf_ = std::move(nb);
    cap_ = ncap;
  }
  auto r = input_->read(buf_.get() + end_, cap_ - end_);
  if (!r.ok()) {
    // Name the line that could not be completed.
    Error e = r.error();
    e.message = fmt::format("{} (at line {})", e.message, line_ + count_newlines(buf_.get(), buf_.get() + end_) + 1);
    return e;
  }
  if (*r == 0) {
    eof_ = true;
    if (end_ > pos_ && buf_[end_ - 1] != '\n') {
      unterminated_line_ = line_ + count_newlines(buf_.get() + pos_, buf_.get() + end_) + 1;
      buf_[end_++] = '\n';  // the spare byte allocated past cap_
    }
  } else {
    end_ += *r;
  }
  return {};
}

Result<bool> TextSource::peek_line(std::string_view& line) {
  for (;;) {
    const char* b = buf_.get() + pos_;
    auto* nl = static_cast<const char*>(std::memchr(b, '\n', end_ - pos_));
    if (nl) {
      const char* e = nl;
      if (e > b && e[-1] == '\r') --e;
      line = std::string_view(b, static_cast<size_t>(e - b));
      return true;
    }
    if (eof_) return false;
    MDS_TRY(fill());
  }
}

Result<bool> TextSource::next_line(std::string_view& line) {
  MDS_ASSIGN_OR_RETURN(bool has, peek_line(line));
  if (!has) return false;
  const char* nl = static_cast<const char*>(std::memchr(line.data() + line.size(), '\n',
                                                        end_ - static_cast<size_t>(line.data() + line.size() - buf_.get())));
  pos_ = static_cast<size_t>(nl + 1 - buf_.get());
  ++line_;
  return true;
}

Result<LineBlock> TextSource::take_lines(size_t max_lines) {
  LineBlock blk;
  blk.first_line = line_ + 1;
  if (max_lines == 0) return blk;
  for (;;) {
    const char* b = buf_.get() + pos_;
    size_t avail = end_ - pos_;
    const char* last = avail ? static_cast<const char*>(memrchr(b, '\n', avail)) : nullptr;
    if (last) {
      // At most max_lines lines (counted only as far as needed).
      size_t n = 0;
      const char* e = after_up_to_n_newlines(b, last + 1, max_lines, n);
      // A small tail at the end of the buffer: compact and read more first, so that
      // blocks stay large (the callers parse blocks in parallel).
      if (n < max_lines && !eof_ && (pos_ > 0 || end_ < cap_) && static_cast<size_t>(e - b) < cap_ / 2) {
        MDS_TRY(fill());
        continue;
      }
      blk.begin = b;
      blk.end = e;
      blk.lines = n;
      pos_ += static_cast<size_t>(e - b);
      line_ += n;
      return blk;
    }
    if (eof_) return blk;
    MDS_TRY(fill());
  }
}

Result<uint64_t> TextSource::skip_lines(uint64_t n) {
  uint64_t skipped = 0;
  while (skipped < n) {
    const char* b = buf_.get() + pos_;
    const char* e = buf_.get() + end_;
    size_t c = count_newlines(b, e);
    if (c >= n - skipped) {
      const char* p = after_nth_newline(b, e, static_cast<size_t>(n - skipped));
      pos_ += static_cast<size_t>(p - b);
      line_ += n - skipped;
      return n;
    }
    // Consume all complete lines; keep a partial last line for the next fill.
    if (c > 0) {
      const char* last = static_cast<const char*>(memrchr(b, '\n', end_ - pos_));
      pos_ += static_cast<size_t>(last + 1 - b);
      line_ += c;
      skipped += c;
    }
    if (eof_) break;
    MDS_TRY(fill());
  }
  return skipped;
}

Status TextSource::seek(uint64_t offset, uint64_t line) {
  if (offset >= buf_offset_ && offset <= buf_offset_ + end_) {
    pos_ = static_cast<size_t>(offset - buf_offset_);
    line_ = line;
    return {};
  }
  if (compression_ == TextCompression::none) {
    if (!input_->seek(offset)) return make_error(Errc::io, "{}: cannot seek to byte {}", name_, offset);
    pos_ = end_ = 0;
    buf_offset_ = offset;
    eof_ = false;
    line_ = line;
    return {};
  }
  if (offset < buf_offset_) MDS_TRY(reopen_input());
  while (buf_offset_ + end_ < offset) {
    if (eof_) return make_error(Errc::io, "{}: cannot seek to byte {}: past the end", name_, offset);
    pos_ = end_;
    MDS_TRY(fill());
  }
  pos_ = static_cast<size_t>(offset - buf_offset_);
  line_ = line;
  return {};
}

bool parse_double_exact(std::string_view s, double& v) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && !s.empty();
}

std::string excerpt(std::string_view s, size_t max_chars) {
  if (s.size() <= max_chars) return std::string(s);
  return std::string(s.substr(0, max_chars)) + "...";
}

}  // namespace mds

namespace mds {

size_t line_parallelism() {
  static const size_t n = [] {
    unsigned h = std::thread::hardware_concurrency();
    return static_cast<size_t>(std::clamp(h == 0 ? 1u : h, 1u, 8u));
  }();
  return n;
}

}  // namespace mds
