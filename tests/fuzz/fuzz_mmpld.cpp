// libFuzzer entry for the MMPLD reader: the input bytes become a file that
// open_mmpld_reader() must reject with an error value or accept, after which every frame
// offered (first and last) is read to the end in small batches. Any crash, sanitizer report
// or hang is a bug in the reader's validation. Seed corpus: files from tests/tools/write_mmpld.py.
// Built only with -DMDSTREAM_FUZZ=ON (clang).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "readers/reader_factories.h"

namespace {

const std::filesystem::path& fuzz_path() {
  static const std::filesystem::path p = [] {
    std::error_code ec;
    std::filesystem::path dir = std::filesystem::is_directory("/dev/shm", ec) ? std::filesystem::path("/dev/shm")
                                                                              : std::filesystem::temp_directory_path();
    return dir / ("mdstream_fuzz_mmpld_" + std::to_string(::getpid()));
  }();
  return p;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto& path = fuzz_path();
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return 0;
    if (size > 0) std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  for (int64_t frame : {int64_t{0}, int64_t{-1}}) {
    mds::ReaderOptions options;
    options.format = mds::InputFormat::mmpld;
    options.frame = frame;
    auto reader = mds::open_mmpld_reader(path, options);
    if (!reader.ok()) continue;
    mds::ParticleBatch batch;
    for (;;) {
      auto n = (*reader)->read(batch, 97);
      if (!n.ok() || *n == 0) break;
    }
  }
  (void)mds::detect_format(path);
  return 0;
}
