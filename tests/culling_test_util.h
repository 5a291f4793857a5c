// Helpers of the culling tests: run a command and capture its output, name a temporary file.
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>

#include <unistd.h>

namespace mds::culling::test {

inline std::string run_capture(const std::string& cmd, int* rc) {
  std::string out;
  FILE* f = popen(cmd.c_str(), "r");
  if (!f) { *rc = -1; return out; }
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, f)) > 0) out.append(buf, n);
  *rc = pclose(f);
  return out;
}

inline std::filesystem::path temp_file(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         ("mds_culling_" + std::to_string(::getpid()) + "_" + name);
}

}  // namespace mds::culling::test
