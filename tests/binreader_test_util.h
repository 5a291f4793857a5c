// Shared helpers for the binary-reader tests (H5MD, MMPLD, raw, detect_format):
// a temporary directory, running the system Python, and draining a reader.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <cstring>
#include <iterator>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "readers/reader.h"

namespace mds::testing {

class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "mds_binreaders_XXXXXX").string();
    char* p = ::mkdtemp(tmpl.data());
    if (p == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = p;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

inline void write_text(const std::filesystem::path& p, const std::string& text) {
  std::ofstream f(p, std::ios::binary);
  f << text;
}

inline std::vector<char> read_bytes(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(f), {});
}

inline void write_bytes(const std::filesystem::path& p, const void* data, size_t n) {
  std::ofstream f(p, std::ios::binary);
  f.write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
}

// Runs MDSTREAM_PYTHON with the given arguments (each shell-quoted); returns the exit code.
inline int run_python(const std::vector<std::string>& args) {
  std::string cmd = MDSTREAM_PYTHON;
  for (const auto& a : args) {
    std::string q = "'";
    for (char c : a) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
    cmd += " " + q + "'";
  }
  int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// Reads a binary file of little-endian values written by numpy's tofile().
template <class T>
std::vector<T> read_array(const std::filesystem::path& p) {
  std::vector<char> b = read_bytes(p);
  std::vector<T> v(b.size() / sizeof(T));
  std::memcpy(v.data(), b.data(), v.size() * sizeof(T));
  return v;
}

struct AllParticles {
  std::vector<double> x, y, z;
  std::vector<int32_t> type;
  std::vector<float> radius;
  std::vector<float> property;
  std::vector<uint32_t> color;
  size_t calls = 0;
};

// Drains `reader` in batches of `batch`; the Error when a read fails.
inline Result<AllParticles> read_all(ParticleReader& reader, size_t batch) {
  AllParticles all;
  ParticleBatch b;
  for (;;) {
    MDS_ASSIGN_OR_RETURN(size_t n, reader.read(b, batch));
    if (n == 0) break;
    EXPECT_EQ(n, b.size());
    EXPECT_LE(n, batch);
    EXPECT_EQ(b.type.size(), n);
    ++all.calls;
    all.x.insert(all.x.end(), b.x.begin(), b.x.end());
    all.y.insert(all.y.end(), b.y.begin(), b.y.end());
    all.z.insert(all.z.end(), b.z.begin(), b.z.end());
    all.type.insert(all.type.end(), b.type.begin(), b.type.end());
    all.radius.insert(all.radius.end(), b.radius.begin(), b.radius.end());
    all.property.insert(all.property.end(), b.property.begin(), b.property.end());
    all.color.insert(all.color.end(), b.color.begin(), b.color.end());
  }
  return all;
}

inline std::string source_path(const std::string& rel) { return std::string(MDSTREAM_SOURCE_DIR) + "/" + rel; }

}  // namespace mds::testing
