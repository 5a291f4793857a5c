// Frame machinery shared by the text readers (LAMMPS dump, XYZ): picking the requested
// frame (skipping earlier frames by counting newlines only, or scanning to the last one and
// seeking back), and the ParticleReader base that streams a frame's atom lines from the
// TextSource in large blocks which the concrete reader parses in parallel
// (parallel_line_ranges: ranges of ~64 KiB taken in turn by one thread per hardware thread).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "readers/reader.h"
#include "readers/text_source.h"

namespace mds {

// An atom count no real file reaches (~10^12); larger counts are rejected before anything
// is allocated, also in compressed files whose size does not bound the count.
inline constexpr uint64_t kMaxTextAtoms = uint64_t{1} << 40;

// What the frame selection needs to know of a header just read.
struct TextFrameExtent {
  uint64_t natoms = 0;      // atom lines that follow the header
  uint64_t first_line = 0;  // line where the frame starts (for messages)
  int64_t timestep = 0;     // the header's simulation step (list_text_frames)
};

// Reads the next frame's header; nullopt at the end of the file. `after` describes what
// precedes (for messages), empty for the first frame.
using TextHeaderFn = std::function<Result<std::optional<TextFrameExtent>>(TextSource& src, const std::string& after)>;

// Opens `path` and positions the source just after the header of options.frame (>= 0, or
// -1 for the last frame); the header read last is the selected one. options.start, when it marks
// options.frame, is sought directly.
Result<std::unique_ptr<TextSource>> open_text_frame(const std::filesystem::path& path, const ReaderOptions& options,
                                                    const TextHeaderFn& read_header);

// Every frame of `path` (list_frames): its headers read, its atom lines skipped.
Result<std::vector<FrameEntry>> list_text_frames(const std::filesystem::path& path, const TextHeaderFn& read_header);

// A TextHeaderFn for a header struct H with fields natoms, first_line and timestep, filled by
// read_header(TextSource&, H&, const std::string& after) -> Result<bool>.
template <class H, class ReadHeader>
TextHeaderFn text_header_fn(H& h, ReadHeader&& read_header) {
  return [&h, read_header](TextSource& src, const std::string& after) -> Result<std::optional<TextFrameExtent>> {
    MDS_ASSIGN_OR_RETURN(bool has, read_header(src, h, after));
    if (!has) return std::optional<TextFrameExtent>{};
    return std::optional<TextFrameExtent>{TextFrameExtent{h.natoms, h.first_line, h.timestep}};
  };
}

// open_text_frame with such a header struct; h holds the selected frame's header after it.
template <class H, class ReadHeader>
Result<std::unique_ptr<TextSource>> open_text_frame(const std::filesystem::path& path, const ReaderOptions& options,
                                                    H& h, ReadHeader&& read_header) {
  return open_text_frame(path, options, text_header_fn(h, std::forward<ReadHeader>(read_header)));
}

// "file:line: file ends inside the frame ..." for a frame that holds fewer atom lines than
// it declares.
Error truncated_frame_error(const TextSource& src, uint64_t frame_line, uint64_t natoms, uint64_t found);

// FrameInfo of a text frame; box_lo/box_hi == nullptr: the frame has no box.
FrameInfo text_frame_info(uint64_t natoms, int64_t timestep, const SimulationCell* cell, bool has_radius,
                          bool has_property = false, bool has_color = false);

// First error found by a parsing thread.
struct LineParseError {
  bool set = false;
  Error error;
};

// Streams the atom lines of one frame. read() takes blocks of complete lines from the
// source and hands them to parse_block(); after the last declared atom check_frame_end()
// validates what follows. An error is remembered and returned again by later read() calls.
class TextFrameReader : public ParticleReader {
 public:
  ~TextFrameReader() override;
  const FrameInfo& info() const override { return info_; }
  // Gives the source back to `relay` when this reader is destroyed without an error
  // (ReaderOptions::relay; nullptr: the source closes with the reader).
  void set_relay(std::shared_ptr<TextSourceRelay> relay) { relay_ = std::move(relay); }
  Result<size_t> read(ParticleBatch& out, size_t max_particles) final;

 protected:
  // info.particle_count is the frame's atom count; frame_line is where the frame starts.
  // reject_unterminated: a final line without '\n' is an error (else it is parsed).
  TextFrameReader(std::unique_ptr<TextSource> src, FrameInfo info, uint64_t frame_line, bool reject_unterminated);

  // Parses blk into out[base, base + blk.lines); done_before = atoms of the frame before blk.
  virtual Status parse_block(const LineBlock& blk, ParticleBatch& out, size_t base, uint64_t done_before) = 0;
  // Called once all declared atoms were read: checks what follows the frame.
  virtual Status check_frame_end() = 0;

  // Runs fn(begin, end, first, lines, error) on ranges of blk in parallel (first = index of
  // the range's first line within blk); returns the error of the earliest range that recorded
  // one (each range stops at its first error, so that is the block's first error by line).
  template <class Fn>
  Status parse_parallel(const LineBlock& blk, Fn&& fn) {
    std::vector<LineParseError> errs(line_range_count(blk, line_parallelism(), kMinLinesPerThread));
    parallel_line_ranges(blk, line_parallelism(), kMinLinesPerThread,
                         [&](size_t range, const char* b, const char* e, size_t first, size_t lines) {
                           fn(b, e, first, lines, errs[range]);
                         });
    for (auto& pe : errs)
      if (pe.set) return pe.error;
    return {};
  }

  // Sizes the arrays of out for n particles (id and radius only when the frame has them).
  static void resize_batch(ParticleBatch& out, size_t n, bool with_id, bool with_radius, bool with_property = false,
                           bool with_color = false);
  // Records "file:line: what" (first error of a range).
  void set_error(LineParseError& err, Errc code, uint64_t line, const std::string& what) const;
  // The token starting at t (at most 40 characters), for messages.
  static std::string token_at(const char* t);
  // "more atom lines than the frame declares" at the next line.
  Error too_many_atoms_error() const;

  uint64_t natoms() const { return info_.particle_count; }
  uint64_t frame_line() const { return frame_line_; }

  static constexpr size_t kMinLinesPerThread = 16384;

  std::unique_ptr<TextSource> src_;
  FrameInfo info_;

 private:
  Error fail(Error e);

  uint64_t frame_line_ = 0;
  std::shared_ptr<TextSourceRelay> relay_;
  bool reject_unterminated_ = false;
  uint64_t remaining_ = 0;
  std::optional<Error> failed_;
};

}  // namespace mds
