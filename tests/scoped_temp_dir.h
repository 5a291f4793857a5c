// A fresh directory under the system temp folder, unique per process and instance
// ("<prefix><pid>_<random>"), removed with everything in it when the object dies.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <random>
#include <string>

namespace mds::test {

struct ScopedTempDir {
  std::filesystem::path p;
  explicit ScopedTempDir(const std::string& prefix) {
    p = std::filesystem::temp_directory_path() /
        (prefix + std::to_string(::getpid()) + "_" + std::to_string(std::random_device{}()));
    std::filesystem::create_directories(p);
  }
  ~ScopedTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(p, ec);
  }
  ScopedTempDir(const ScopedTempDir&) = delete;
  ScopedTempDir& operator=(const ScopedTempDir&) = delete;
};

}  // namespace mds::test
