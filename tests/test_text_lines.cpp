// The line machinery of the text readers (preprocess/readers/text_source.h): count_newlines must
// equal std::count for every length, alignment and byte value (its SSE2 path sums byte counters
// that must not wrap), and parallel_line_ranges must hand out contiguous ranges that start at
// line starts, each exactly once, with each range's line count and first line index as a
// serial count gives them, on no more threads than line_threads says.
#include <algorithm>
#include <cstdint>
#include <mutex>
#include <set>
#include <thread>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "readers/text_source.h"

namespace {

size_t reference_count(const char* b, const char* e) { return size_t(std::count(b, e, '\n')); }

TEST(TextLines, CountNewlinesEqualsStdCountAtEveryLengthAndOffset) {
  std::mt19937 rng(7);
  // Bytes next to '\n' in value or bit pattern (0x0a ^ 0x80, 0x0b, 0x09), zero, 0xff, and text.
  const char alphabet[] = {'\n', char(0x8a), char(0x0b), char(0x09), char(0x00), char(0xff), '1', ' ', '.', '\r'};
  std::vector<char> buf(700 + 32);
  for (char& c : buf) c = alphabet[rng() % sizeof(alphabet)];
  for (size_t offset = 0; offset < 32; ++offset)
    for (size_t len = 0; len <= 700; ++len) {
      const char* b = buf.data() + offset;
      ASSERT_EQ(mds::count_newlines(b, b + len), reference_count(b, b + len)) << "offset " << offset << " length " << len;
    }
}

TEST(TextLines, CountNewlinesDoesNotWrapOnLongRunsOfNewlines) {
  // All '\n': every byte counter of the SSE2 path takes its maximum between two flushes.
  for (const size_t len : {size_t(16 * 255 - 1), size_t(16 * 255), size_t(16 * 255 + 1), size_t(16 * 255 * 3 + 7),
                           size_t(1) << 20}) {
    const std::string s(len, '\n');
    EXPECT_EQ(mds::count_newlines(s.data(), s.data() + s.size()), len);
  }
  // A long random text with a newline density like a dump's.
  std::mt19937 rng(11);
  std::string s(3 << 20, 'x');
  for (char& c : s) c = (rng() % 29 == 0) ? '\n' : char('0' + rng() % 10);
  for (const size_t cut : {size_t(0), size_t(5), size_t(4080), size_t(4081), size_t(65537)})
    EXPECT_EQ(mds::count_newlines(s.data() + cut, s.data() + s.size()), reference_count(s.data() + cut, s.data() + s.size()));
}

// A block of `lines` lines of random length (0..max_len characters before the '\n').
std::string random_block(size_t lines, size_t max_len, uint32_t seed) {
  std::mt19937 rng(seed);
  std::string s;
  for (size_t i = 0; i < lines; ++i) {
    s.append(rng() % (max_len + 1), char('a' + rng() % 26));
    s.push_back('\n');
  }
  return s;
}

struct Part {
  size_t part, first, lines;
  const char *begin, *end;
  std::thread::id thread;
};

TEST(TextLines, ParallelLineRangesMatchASerialCount) {
  // Up to ~6 MB: blocks of one range per thread and blocks of many 64 KiB ranges (and of
  // kMaxLineRanges, where ranges grow beyond 64 KiB).
  for (const size_t lines : {size_t(1), size_t(7), size_t(1000), size_t(100000), size_t(200000)})
    for (const size_t max_len : {size_t(0), size_t(3), size_t(60)})
      for (const size_t max_parts : {size_t(1), size_t(2), size_t(3), size_t(8)})
        for (const size_t min_lines : {size_t(1), size_t(16), size_t(16384)}) {
          const std::string text = random_block(lines, max_len, uint32_t(lines * 131 + max_len));
          mds::LineBlock blk;
          blk.begin = text.data();
          blk.end = text.data() + text.size();
          blk.lines = lines;
          blk.first_line = 1;
          std::mutex mu;
          std::vector<Part> got;
          const size_t parts = mds::parallel_line_ranges(
              blk, max_parts, min_lines, [&](size_t part, const char* b, const char* e, size_t first, size_t n) {
                std::lock_guard lock(mu);
                got.push_back({part, first, n, b, e, std::this_thread::get_id()});
              });
          SCOPED_TRACE("lines " + std::to_string(lines) + " max_len " + std::to_string(max_len) + " parts " +
                       std::to_string(max_parts) + " min " + std::to_string(min_lines));
          ASSERT_EQ(parts, mds::line_range_count(blk, max_parts, min_lines));
          ASSERT_EQ(got.size(), parts);
          ASSERT_LE(parts, mds::kMaxLineRanges);
          std::set<std::thread::id> threads;
          for (const Part& p : got) threads.insert(p.thread);
          EXPECT_LE(threads.size(), mds::line_threads(blk, max_parts, min_lines));
          if (parts > 1) {
            EXPECT_GE(parts, mds::line_threads(blk, max_parts, min_lines));
          }
          std::sort(got.begin(), got.end(), [](const Part& a, const Part& b) { return a.part < b.part; });
          const char* at = blk.begin;
          size_t first = 0;
          for (size_t i = 0; i < parts; ++i) {
            EXPECT_EQ(got[i].part, i);
            EXPECT_EQ(got[i].begin, at);
            EXPECT_TRUE(got[i].begin == blk.begin || got[i].begin[-1] == '\n');  // starts a line
            EXPECT_EQ(got[i].lines, reference_count(got[i].begin, got[i].end));
            EXPECT_EQ(got[i].first, first);
            first += got[i].lines;
            at = got[i].end;
          }
          EXPECT_EQ(at, blk.end);
          EXPECT_EQ(first, lines);
        }
}

}  // namespace
