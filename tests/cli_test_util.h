// Running the `mdstream` executable from a test: the command line, its exit code, its stderr, and
// the EXR images it writes. Header-only, for the CLI suites (test_render_cli, test_render_path).
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <tinyexr.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace mds::testing {

// CTest runs test cases as parallel processes: each keeps its stderr capture to itself.
inline std::string cli_stderr_path() { return "/tmp/mds_cli_err." + std::to_string(::getpid()) + ".txt"; }
// Removes the capture when the test process exits (one object per process: an inline variable).
struct CliStderrCleanup {
  ~CliStderrCleanup() { std::remove(cli_stderr_path().c_str()); }
};
inline CliStderrCleanup cli_stderr_cleanup;

// Runs `env mdstream args` (env: "NAME=value " assignments or empty) with stderr captured for
// cli_stderr(); stdout as the args redirect it. The exit code, -1 when killed.
inline int run_mdstream(const std::string& args, const std::string& env = "") {
  const std::string cmd = env + std::string(MDSTREAM_BIN) + " " + args + " 2>" + cli_stderr_path();
  const int r = std::system(cmd.c_str());
  return WIFEXITED(r) ? WEXITSTATUS(r) : -1;
}

// The stderr of the last run_mdstream of this process.
inline std::string cli_stderr() {
  std::ifstream f(cli_stderr_path());
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// An EXR's float RGBA pixels (4 per pixel), empty with a test failure when unreadable.
inline std::vector<float> load_exr(const std::filesystem::path& p) {
  float* rgba = nullptr;
  int w = 0, h = 0;
  const char* err = nullptr;
  if (LoadEXR(&rgba, &w, &h, p.c_str(), &err) != TINYEXR_SUCCESS) {
    ADD_FAILURE() << p << ": " << (err ? err : "unreadable");
    return {};
  }
  std::vector<float> v(rgba, rgba + size_t(4) * size_t(w) * size_t(h));
  std::free(rgba);
  return v;
}

// Two EXR renders of w x h pixels: the pixels the first covers, and those where any channel
// differs by more than the renderer's tolerance of 0.1 (failures for unreadable or mismatched
// images leave both counts 0).
struct ExrDifference {
  size_t covered = 0, differing = 0;
};
inline ExrDifference compare_exr(const std::filesystem::path& first, const std::filesystem::path& second, size_t w,
                                 size_t h) {
  const std::vector<float> a = load_exr(first), b = load_exr(second);
  EXPECT_EQ(a.size(), 4 * w * h) << first;
  EXPECT_EQ(b.size(), a.size()) << second;
  ExrDifference d;
  if (a.size() != 4 * w * h || b.size() != a.size()) return d;
  for (size_t p = 0; p < a.size(); p += 4) {
    d.covered += a[p + 3] > 0.0f;
    float m = 0.0f;
    for (size_t c = 0; c < 4; ++c) m = std::max(m, std::abs(a[p + c] - b[p + c]));
    d.differing += m > 0.1f;
  }
  return d;
}

}  // namespace mds::testing
