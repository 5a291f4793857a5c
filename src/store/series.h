// A time series of stores: one store per frame of a trajectory (`convert --frames` writes them)
// and an index that lists them in order with their times. The index is ParaView's file-series
// JSON, so ParaView users know it and tools that write it for other formats need no new syntax:
//   {
//     "file-series-version" : "1.0",
//     "files" : [
//       { "name" : "run.0000.mds", "time" : 0 },
//       { "name" : "run.0001.mds", "time" : 1000 }
//     ]
//   }
// A name is a path relative to the index's folder (or absolute); the time is the frame's
// simulation step (any finite number is accepted). The file's name ends in ".series"
// (`run.mds.series`). docs/store-format.md "Store series" describes it. No Vulkan.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/result.h"

namespace mds::store {

inline constexpr const char* kSeriesVersion = "1.0";  // "file-series-version" read and written

struct SeriesFrame {
  std::string name;             // as the index writes it
  std::filesystem::path path;   // name resolved against the index's folder
  double time = 0.0;
};

struct Series {
  std::filesystem::path file;   // the index
  std::vector<SeriesFrame> frames;
};

// True for a path whose name ends in ".series" (how render, view, info and convert tell an
// index from a store).
bool is_series_path(const std::filesystem::path& path);

// Reads an index. Errors (Errc::io, Errc::format) name the file and the place: the byte offset
// of a JSON syntax error, or the JSON pointer of a bad value ("/files/2/time"). The stores are
// not opened here: a missing one is reported by whoever opens it.
Result<Series> read_series(const std::filesystem::path& file);

// The index text for `frames` (their names and times).
std::string series_json(const std::vector<SeriesFrame>& frames);

// Writes the index atomically (core/text_file.h).
Status write_series(const std::filesystem::path& file, const std::vector<SeriesFrame>& frames);

}  // namespace mds::store
