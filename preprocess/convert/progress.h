// Progress display of the converter: a one-line bar on stderr, redrawn at most ~10 times a
// second. Disabled (all calls are no-ops) unless constructed enabled, which the CLI does
// only when stderr is a terminal and --quiet is not given.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace mds::convert {

class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled) {}
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Starts a stage ("read", "partition", "build") with `total` units (particles).
  void stage(const std::string& name, uint64_t total);
  void update(uint64_t done);
  void finish();  // ends the current line
  bool enabled() const { return enabled_; }

 private:
  void draw(bool force);
  bool enabled_;
  bool drawn_ = false;
  std::string name_;
  uint64_t total_ = 0;
  uint64_t done_ = 0;
  std::chrono::steady_clock::time_point start_{}, last_{};
};

}  // namespace mds::convert
