// libFuzzer entry for the store series index (store/series.h): the input bytes become a
// .series file that read_series() must reject with an error value or accept; an accepted index
// has at least one frame, each with a non-empty name and a finite time, and writing it back and
// reading that again gives the same frames. Crashes, sanitizer reports, hangs and broken
// invariants (abort()) are bugs. Seeds: indexes written by `convert -o RUN.mds.series`.
#include <cmath>

#include "fuzz_harness.h"
#include "store/series.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto& path = mds::fuzz::input_path("fuzz_series", ".series");
  mds::fuzz::write_input(path, data, size);
  auto s = mds::store::read_series(path);
  if (!s.ok()) return 0;
  if (s->frames.empty()) std::abort();
  for (const auto& f : s->frames)
    if (f.name.empty() || !std::isfinite(f.time)) std::abort();
  if (!mds::store::write_series(path, s->frames).ok()) std::abort();
  auto again = mds::store::read_series(path);
  if (!again.ok() || again->frames.size() != s->frames.size()) std::abort();
  for (size_t k = 0; k < s->frames.size(); ++k)
    if (again->frames[k].name != s->frames[k].name || again->frames[k].time != s->frames[k].time) std::abort();
  return 0;
}
