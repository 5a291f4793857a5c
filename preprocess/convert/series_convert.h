// `convert ... -o RUN.mds.series`: a trajectory to a series of stores (store/series.h), one
// store per frame, each converted by convert() as if alone (same options, same memory budget),
// then the index. With one input its frames are the series (`--frames`, default all; a text
// input's frames are listed once and each conversion seeks to its frame, in the source the frame
// before left open: ReaderOptions::relay; so a compressed file is decompressed twice in all, for
// the list and for the frames, not once per frame). With several inputs
// each input is one frame (the per-step files LAMMPS writes with `dump ... dump.*.txt`), taken
// at ReaderOptions::frame and ordered by the simulation step each declares; when two declare the
// same step (formats without one declare 0) the order of the command line stands and the
// series' times are the positions.
//
// The stores are RUN.0000.mds, RUN.0001.mds, ... next to the index (RUN: the index's name without
// ".series" and ".mds"; at least 4 digits). Each is written under a temporary name and renamed
// into place only when every frame has converted, then the index is written: on an error while
// converting, nothing of this call is left and the stores and index of an earlier run stay.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "convert/converter.h"
#include "core/frame_selection.h"
#include "store/series.h"

namespace mds::convert {

struct SeriesFrameReport {
  int64_t input_frame = 0;   // the frame's index in its input
  int64_t timestep = 0;      // as the input declares it
  ConvertReport report;
};

struct SeriesReport {
  std::vector<store::SeriesFrame> frames;  // as the index lists them (paths of the stores)
  std::vector<SeriesFrameReport> reports;  // per frame, in the same order
  double seconds_total = 0;
};

// Called after each store is written: (position in the series, frames in the series, report).
using SeriesProgressFn = std::function<void(size_t, size_t, const SeriesFrameReport&)>;

// o.output is the index (store::is_series_path). `frames`: which frames of the one input
// (nullopt = all); with several inputs it must be nullopt.
Result<SeriesReport> convert_series(const ConvertOptions& o, const std::optional<FrameSelection>& frames,
                                    const SeriesProgressFn& on_frame = {});

// The store of position k of n for the index `series` (RUN.mds.series, 3, 10 -> RUN.0003.mds).
std::filesystem::path series_store_path(const std::filesystem::path& series, size_t k, size_t n);

}  // namespace mds::convert
