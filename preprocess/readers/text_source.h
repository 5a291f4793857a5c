// Buffered line source for the text readers (LAMMPS dump, XYZ).
//
// Reads plain, gzip (zlib) and zstd (libzstd streaming) files; the compression is found
// from the magic bytes, not the extension. Data comes in large chunks (8 MiB by default)
// into one buffer; lines are handed out as views into that buffer, either one at a time
// (headers) or as blocks of many complete lines (the hot loop of the readers, which parse
// blocks in parallel). Line numbers are tracked for error messages ("file:line: ...").
//
// Views stay valid until the next call that may refill the buffer (next_line, peek_line,
// take_lines, skip_lines, seek).
#pragma once

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cstring>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/result.h"

namespace mds {

// A run of complete lines; every line, including the last, ends with '\n'.
struct LineBlock {
  const char* begin = nullptr;
  const char* end = nullptr;   // one past the last '\n'
  size_t lines = 0;
  uint64_t first_line = 0;     // 1-based line number of the first line
};

enum class TextCompression { none, gzip, zstd };

class TextSource {
 public:
  class Input;  // raw byte input (plain / gzip / zstd), defined in text_source.cpp

  static Result<std::unique_ptr<TextSource>> open(const std::filesystem::path& path,
                                                  size_t buffer_bytes = size_t{8} << 20);
  ~TextSource();
  TextSource(const TextSource&) = delete;
  TextSource& operator=(const TextSource&) = delete;

  // The path as given, for messages.
  const std::string& name() const { return name_; }
  TextCompression compression() const { return compression_; }
  uint64_t file_size() const { return file_size_; }
  // Bytes of the file not yet consumed, when known without decompressing (plain files).
  std::optional<uint64_t> remaining_bytes() const;

  // Number of lines consumed so far (= line number of the last consumed line).
  uint64_t line() const { return line_; }
  // Uncompressed byte offset of the next unread byte.
  uint64_t tell() const { return buf_offset_ + pos_; }
  // Line number of the file's final line when it had no '\n' (known once the end of the
  // file has been reached), else 0.
  uint64_t unterminated_line() const { return unterminated_line_; }

  // Next line without its '\n' (and without a trailing '\r'). Returns false at the end of
  // the file. peek_line() does not consume the line.
  Result<bool> next_line(std::string_view& line);
  Result<bool> peek_line(std::string_view& line);
  // Up to max_lines complete lines, as many as the buffer holds; lines == 0 at the end of
  // the file.
  Result<LineBlock> take_lines(size_t max_lines);
  // Skips up to n lines without looking at them; returns how many were skipped (< n only
  // at the end of the file).
  Result<uint64_t> skip_lines(uint64_t n);
  // Repositions at an uncompressed offset previously obtained from tell(), where the
  // line counter was `line`. Compressed inputs are re-read from the start.
  Status seek(uint64_t offset, uint64_t line);

 private:
  TextSource() = default;
  Status fill();            // compacts the buffer and reads more; sets eof_
  Status reopen_input();

  std::filesystem::path path_;
  std::string name_;
  TextCompression compression_ = TextCompression::none;
  uint64_t file_size_ = 0;
  std::unique_ptr<Input> input_;
  std::unique_ptr<char[]> buf_;
  size_t cap_ = 0;          // usable capacity (one extra byte is allocated for a final '\n')
  size_t pos_ = 0, end_ = 0;
  uint64_t buf_offset_ = 0; // uncompressed offset of buf_[0]
  uint64_t line_ = 0;
  uint64_t unterminated_line_ = 0;
  bool eof_ = false;
};

// --- token helpers shared by the text readers ---

inline bool is_blank(char c) { return c == ' ' || c == '\t'; }
inline bool is_token_end(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

inline std::string_view trim(std::string_view s) {
  while (!s.empty() && (is_blank(s.front()) || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (is_blank(s.back()) || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Parses the whole of `s` (after trimming) as an integer; false when it is not one.
// `overflow` is set when it is a number that does not fit.
template <class Int>
bool parse_int_exact(std::string_view s, Int& v, bool* overflow = nullptr) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (overflow) *overflow = r.ec == std::errc::result_out_of_range;
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && !s.empty();
}

bool parse_double_exact(std::string_view s, double& v);

// Shortens a line for an error message.
std::string excerpt(std::string_view s, size_t max_chars = 60);

}  // namespace mds

namespace mds {

// Number of '\n' bytes in [b, e). With SSE2 (every x86-64): 16 bytes a step, the compare masks
// (0xff = -1 per '\n') subtracted into byte counters that are summed (psadbw) every 255 steps
// before they can wrap; 31 GB/s on a cached LAMMPS dump against 9.3 GB/s for the eight-byte
// SWAR loop it replaced, which stays as the fallback (exact zero-byte test on the XOR). The
// text readers count every block twice (TextSource::take_lines, parallel_line_ranges).
inline size_t count_newlines(const char* b, const char* e) {
  size_t n = 0;
#if defined(__SSE2__)
  const __m128i nl = _mm_set1_epi8('\n');
  while (e - b >= 16) {
    __m128i acc = _mm_setzero_si128();
    for (int k = 0; k < 255 && e - b >= 16; ++k, b += 16)
      acc = _mm_sub_epi8(acc, _mm_cmpeq_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(b)), nl));
    const __m128i sums = _mm_sad_epu8(acc, _mm_setzero_si128());  // two 64-bit byte sums
    // Each half is at most 8 x 255: the low 32 bits hold it (and _mm_cvtsi128_si32 exists on 32-bit x86 too).
    n += static_cast<size_t>(_mm_cvtsi128_si32(sums)) + static_cast<size_t>(_mm_cvtsi128_si32(_mm_unpackhi_epi64(sums, sums)));
  }
#else
  constexpr uint64_t k7f = 0x7f7f7f7f7f7f7f7fULL, knl = 0x0a0a0a0a0a0a0a0aULL;
  while (e - b >= 8) {
    uint64_t w;
    std::memcpy(&w, b, 8);
    const uint64_t x = w ^ knl;                      // zero bytes where w has '\n'
    const uint64_t t = ((x & k7f) + k7f) | x;        // high bit set in every non-zero byte
    const uint64_t ones = (~t & ~k7f) >> 7;          // 0x01 in each '\n' byte
    n += static_cast<size_t>((ones * 0x0101010101010101ULL) >> 56);  // byte sum (<= 8)
    b += 8;
  }
#endif
  for (; b < e; ++b) n += (*b == '\n');
  return n;
}

// Parts worth using for parallel parsing on this machine (hardware threads, capped at 8).
size_t line_parallelism();

// Parallel parsing cuts a block into ranges of about kLineRangeBytes (at most kMaxLineRanges),
// which the threads take in order from a shared counter: a thread that gets a core late (the
// block's other threads share the cores with the reader pipeline's consumer) takes fewer ranges
// instead of holding up the block. 64 KiB is ~1,800 LAMMPS atom lines, ~80 us of parsing.
inline constexpr size_t kLineRangeBytes = size_t(64) << 10;
inline constexpr size_t kMaxLineRanges = 256;

// Threads parallel_line_ranges uses for blk: min(max_threads, lines / min_lines_per_thread),
// at least 1.
inline size_t line_threads(const LineBlock& blk, size_t max_threads, size_t min_lines_per_thread) {
  return std::max<size_t>(1, std::min(max_threads, blk.lines / std::max<size_t>(1, min_lines_per_thread)));
}

// Ranges parallel_line_ranges cuts blk into: 1 when it runs on one thread, else about one per
// kLineRangeBytes, at least one per thread, at most kMaxLineRanges.
inline size_t line_range_count(const LineBlock& blk, size_t max_threads, size_t min_lines_per_thread) {
  const size_t threads = line_threads(blk, max_threads, min_lines_per_thread);
  if (threads <= 1) return 1;
  const size_t bytes = static_cast<size_t>(blk.end - blk.begin);
  return std::clamp(bytes / kLineRangeBytes, std::min(threads, kMaxLineRanges), kMaxLineRanges);
}

// Cuts `blk` at line boundaries into line_range_count(blk, ...) ranges and calls
// fn(range, begin, end, first_index, lines) once for each, on line_threads(blk, ...) threads
// (the calling thread and others of their own); returns the number of ranges. first_index is
// the index of the range's first line within the block. A range may hold no line. The threads
// first count the ranges' lines (taking ranges from a shared counter), then parse them in the
// same way; a range's first index is the sum of the counts before it, so parsing waits only
// until every range has been counted (a few tens of us), not for the other threads to start.
// Precondition: blk.lines is the number of '\n' in [blk.begin, blk.end).
template <class Fn>
size_t parallel_line_ranges(const LineBlock& blk, size_t max_threads, size_t min_lines_per_thread, Fn&& fn) {
  const size_t threads = line_threads(blk, max_threads, min_lines_per_thread);
  const size_t ranges = line_range_count(blk, max_threads, min_lines_per_thread);
  if (ranges <= 1) {
    fn(size_t{0}, blk.begin, blk.end, size_t{0}, blk.lines);
    return 1;
  }
  // Cut points: split the bytes evenly, then move each cut past the next '\n'.
  std::vector<const char*> cut(ranges + 1);
  cut[0] = blk.begin;
  cut[ranges] = blk.end;
  const size_t bytes = static_cast<size_t>(blk.end - blk.begin);
  for (size_t i = 1; i < ranges; ++i) {
    const char* p = std::max(cut[i - 1], blk.begin + bytes * i / ranges);
    // p > begin; step to just after the '\n' that ends the line containing p[-1].
    const char* nl = static_cast<const char*>(std::memchr(p - 1, '\n', static_cast<size_t>(blk.end - (p - 1))));
    cut[i] = nl + 1;
  }
  std::vector<size_t> count(ranges);
  std::atomic<size_t> next_count{0}, counted{0}, next_parse{0};
  auto run = [&] {
    for (size_t i; (i = next_count.fetch_add(1, std::memory_order_relaxed)) < ranges;) {
      count[i] = count_newlines(cut[i], cut[i + 1]);
      if (counted.fetch_add(1, std::memory_order_acq_rel) + 1 == ranges) counted.notify_all();
    }
    // Every range taken for counting; wait for the ones still being counted.
    for (size_t c; (c = counted.load(std::memory_order_acquire)) < ranges;) counted.wait(c, std::memory_order_acquire);
    size_t first = 0, summed = 0;  // first index of range i: the counts of ranges [0, i), summed as i grows
    for (size_t i; (i = next_parse.fetch_add(1, std::memory_order_relaxed)) < ranges;) {
      for (; summed < i; ++summed) first += count[summed];
      fn(i, cut[i], cut[i + 1], first, count[i]);
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (size_t t = 1; t < threads; ++t) pool.emplace_back(run);
  run();
  for (auto& t : pool) t.join();
  return ranges;
}

}  // namespace mds
