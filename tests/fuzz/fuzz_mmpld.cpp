// libFuzzer entry for the MMPLD reader: the input bytes become a file that
// open_mmpld_reader() must reject with an error value or accept, after which every frame
// offered (first and last) is read to the end in small batches. Any crash, sanitizer report
// or hang is a bug in the reader's validation. Seed corpus: files from tests/tools/write_mmpld.py.
// Built only with -DMDSTREAM_FUZZ=ON (clang).
#include "fuzz_harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  mds::fuzz::run_reader(data, size, "mdstream_fuzz_mmpld", mds::open_mmpld_reader,
                        {.format = mds::InputFormat::mmpld, .frames = {0, -1}, .batch = 97, .check_counts = false,
                         .detect_format = true, .property = "intensity", .color = true});
  return 0;
}
