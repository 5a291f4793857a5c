// Progress bar on stderr (see progress.h).
#include "convert/progress.h"

#include <cstdio>

namespace mds::convert {

Progress::~Progress() { finish(); }

void Progress::stage(const std::string& name, uint64_t total) {
  if (!enabled_) return;
  finish();
  name_ = name;
  total_ = total;
  done_ = 0;
  start_ = std::chrono::steady_clock::now();
  last_ = {};
  draw(true);
}

void Progress::update(uint64_t done) {
  if (!enabled_) return;
  done_ = done;
  draw(false);
}

void Progress::draw(bool force) {
  const auto now = std::chrono::steady_clock::now();
  if (!force && now - last_ < std::chrono::milliseconds(100)) return;
  last_ = now;
  const double frac = total_ > 0 ? std::min(1.0, double(done_) / double(total_)) : 0.0;
  const int width = 30;
  const int fill = int(frac * width);
  char bar[width + 1];
  for (int i = 0; i < width; ++i) bar[i] = i < fill ? '#' : '.';
  bar[width] = '\0';
  const double secs = std::chrono::duration<double>(now - start_).count();
  const double rate = secs > 0 ? double(done_) / secs / 1e6 : 0.0;
  std::fprintf(stderr, "\r%-10s [%s] %5.1f%%  %llu/%llu  %.2f M/s ", name_.c_str(), bar, frac * 100.0,
               static_cast<unsigned long long>(done_), static_cast<unsigned long long>(total_), rate);
  std::fflush(stderr);
  drawn_ = true;
}

void Progress::finish() {
  if (!enabled_ || !drawn_) return;
  draw(true);
  std::fputc('\n', stderr);
  drawn_ = false;
}

}  // namespace mds::convert
