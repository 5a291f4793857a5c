// Which frames of a sequence to take: `convert --frames` (frames of a trajectory file) and
// `render --series-frames` (frames of a store series, store/series.h) read the same syntax,
// Python's slices, which ParaView and OVITO users know from their scripting consoles:
//   all        every frame (= ":")
//   last       the last frame (= "-1")
//   K          frame K (0 = first; negative counts from the end: -1 = last)
//   A:B[:S]    frames A, A+S, ... below B (B exclusive; A or B empty = the start or the end;
//              negative A or B count from the end; S >= 1, default 1)
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace mds {

struct FrameSelection {
  std::string text;                    // as given, for messages
  bool single = false;                 // K or last: exactly one frame, an error when out of range
  std::optional<int64_t> start, stop;  // nullopt: the start / the end of the sequence
  int64_t step = 1;                    // >= 1
};

// Errc::invalid_argument naming the text and what was expected.
Result<FrameSelection> parse_frame_selection(std::string_view text);

// The indices `sel` selects from a sequence of `count` frames, increasing. A single index out of
// [-count, count) is Errc::invalid_argument naming the count; so is a slice that selects nothing.
Result<std::vector<int64_t>> select_frames(const FrameSelection& sel, int64_t count);

}  // namespace mds
