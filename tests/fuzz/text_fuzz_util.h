// Shared by the libFuzzer targets: write the input to a per-process temporary file and
// drain a reader opened on it.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "readers/reader_factories.h"

namespace mds::fuzz {

inline const std::filesystem::path& input_path(const char* tag) {
  static const std::filesystem::path p =
      std::filesystem::temp_directory_path() / (std::string(tag) + "_" + std::to_string(::getpid()) + ".in");
  return p;
}

template <class Open>
void run_reader(const uint8_t* data, size_t size, const char* tag, Open open) {
  const auto& path = input_path(tag);
  {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::abort();
    if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
  }
  for (int64_t frame : {int64_t{0}, int64_t{-1}, int64_t{1}}) {
    ReaderOptions o;
    o.frame = frame;
    auto r = open(path, o);
    if (!r.ok()) continue;
    ParticleBatch b;
    uint64_t total = 0;
    while (true) {
      auto n = (*r)->read(b, 7);
      if (!n.ok() || *n == 0) break;
      if (*n != b.size() || b.type.size() != b.size()) std::abort();
      total += *n;
      if (total > (*r)->info().particle_count) std::abort();  // more than the frame declares
    }
    (void)(*r)->type_names();
  }
}

}  // namespace mds::fuzz
