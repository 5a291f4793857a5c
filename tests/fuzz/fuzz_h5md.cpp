// libFuzzer entry for the H5MD reader (HDF5 C library included): the input bytes become a file that
// open_h5md_reader() must reject with an error value or accept, after which every frame
// offered (first and last) is read to the end in small batches. Any crash, sanitizer report
// or hang is a bug in the reader's validation. Seed corpus: small H5MD files written with h5py (see tests/test_h5md_reader.cpp).
// Built only with -DMDSTREAM_FUZZ=ON (clang).
// Run with -detect_leaks=0 and ASAN_OPTIONS=allocator_may_return_null=1: libhdf5 1.10.8
// itself leaks a few hundred bytes on some corrupted object headers and asks malloc for
// absurd sizes from corrupted metadata (H5C_protect), which it then handles as an error.
// mdstream's own HDF5 ids are all closed (checked with H5Fget_obj_count).
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
    return dir / ("mdstream_fuzz_h5md_" + std::to_string(::getpid()));
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
    options.format = mds::InputFormat::h5md;
    options.frame = frame;
    auto reader = mds::open_h5md_reader(path, options);
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
