// Shared by the libFuzzer targets (tests/fuzz/fuzz_*.cpp): the input bytes go to a
// per-process scratch file, which a reader then opens at several frames and drains in small
// batches. Errors are fine; crashes, sanitizer reports, hangs and broken reader invariants
// (checked with abort()) are bugs.
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "readers/reader_factories.h"
#include "readers/replicate_reader.h"
#include "readers/wrap_reader.h"

namespace mds::fuzz {

// The process's scratch file: /dev/shm (or the temporary directory) /<tag>_<pid><suffix>,
// removed at exit. The first call fixes the name.
inline const std::filesystem::path& input_path(const char* tag, const char* suffix = "") {
  static const std::filesystem::path p = [&] {
    std::error_code ec;
    const std::filesystem::path dir = std::filesystem::is_directory("/dev/shm", ec)
                                          ? std::filesystem::path("/dev/shm")
                                          : std::filesystem::temp_directory_path();
    return dir / (std::string(tag) + "_" + std::to_string(::getpid()) + suffix);
  }();
  static const bool cleanup_registered = [] {
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove(p, ec);
    });
    return true;
  }();
  (void)cleanup_registered;
  return p;
}

// Writes the bytes to `path` (replacing it); aborts when that fails (a broken harness).
inline void write_input(const std::filesystem::path& path, const uint8_t* data, size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
}

struct DrainOptions {
  InputFormat format = InputFormat::automatic;  // ReaderOptions::format
  std::vector<int64_t> frames = {0, -1, 1};     // frames opened, one reader each
  size_t batch = 7;                             // max_particles per read()
  bool check_counts = true;   // abort when a batch's arrays disagree or a frame yields more than it declares
  bool detect_format = false; // also run detect_format() on the file
  // Each frame is also opened asking for this per-particle property (ReaderOptions::property;
  // empty: not); a reader that has it must give one value per particle.
  std::string property;
  // Each frame is also opened asking for per-particle colours (ReaderOptions::color); a reader
  // that has them must give one per particle.
  bool color = false;
};

// Writes the input to the scratch file `tag` and drains open(path, options) at every frame.
template <class Open>
void run_reader(const uint8_t* data, size_t size, const char* tag, Open open, const DrainOptions& d = {}) {
  const auto& path = input_path(tag);
  write_input(path, data, size);
  for (int64_t frame : d.frames) for (const int extra : {0, 1, 2, 3, 4}) {  // nothing, the property, colours, wrapped, replicated
    const bool with_property = extra == 1, with_color = extra == 2, wrapped = extra == 3, replicated = extra == 4;
    if ((with_property && d.property.empty()) || (with_color && !d.color)) continue;
    ReaderOptions o;
    o.format = d.format;
    o.frame = frame;
    if (with_property) o.property = d.property;
    o.color = with_color;
    auto r = open(path, o);
    if (!r.ok()) continue;
    if (wrapped) {  // positions wrapped into the cell (convert --wrap): finite in, finite out
      r = wrap_reader(std::move(*r), path.string());
      if (!r.ok()) continue;
    }
    if (replicated) {  // three periodic images (convert --replicate): finite in, finite out
      r = replicate_reader(std::move(*r), {3, 1, 1}, path.string());
      if (!r.ok()) continue;
    }
    const bool has_property = (*r)->info().has_property, has_color = (*r)->info().has_color;
    if (has_property != with_property || has_color != with_color) std::abort();  // asked for and found, or an error at open
    ParticleBatch b;
    uint64_t total = 0;
    while (true) {
      auto n = (*r)->read(b, d.batch);
      if (!n.ok() || *n == 0) break;
      if (b.property.size() != (has_property ? b.size() : 0) || b.color.size() != (has_color ? b.size() : 0))
        std::abort();
      for (size_t i = 0; (wrapped || replicated) && i < b.size(); ++i)
        if (!std::isfinite(b.x[i]) || !std::isfinite(b.y[i]) || !std::isfinite(b.z[i])) std::abort();
      if (d.check_counts) {
        if (*n != b.size() || b.type.size() != b.size()) std::abort();
        total += *n;
        if (total > (*r)->info().particle_count) std::abort();  // more than the frame declares
      }
    }
    if (d.check_counts) (void)(*r)->type_names();
  }
  if (d.detect_format) (void)detect_format(path);
}

// list_frames() of the scratch file (written by run_reader), then every listed frame opened at
// its mark (ReaderOptions::start) with one source relayed from frame to frame
// (ReaderOptions::relay: the series converter's path) and drained: a frame that opens
// must yield exactly the count the list gave it, and the list's indices must run 0, 1, ...
template <class Open>
void run_frame_list(const char* tag, Open open, InputFormat format) {
  const auto& path = input_path(tag);
  ReaderOptions lo;
  lo.format = format;
  auto frames = list_frames(path, lo);
  if (!frames.ok()) return;
  lo.relay = std::make_shared<TextSourceRelay>();
  for (size_t k = 0; k < frames->size() && k < 8; ++k) {
    const FrameEntry& e = (*frames)[k];
    if (e.index != int64_t(k) || e.mark.index != int64_t(k)) std::abort();
    ReaderOptions o = lo;
    o.frame = e.index;
    o.start = e.mark;
    auto r = open(path, o);
    if (!r.ok()) continue;  // the header parsed for the list; atom lines may still be bad
    if ((*r)->info().particle_count != e.particle_count || (*r)->info().timestep != e.timestep) std::abort();
    ParticleBatch b;
    uint64_t total = 0;
    while (true) {
      auto n = (*r)->read(b, 13);
      if (!n.ok() || *n == 0) break;
      total += *n;
      if (total > e.particle_count) std::abort();
    }
  }
}

}  // namespace mds::fuzz
