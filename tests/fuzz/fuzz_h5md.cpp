// libFuzzer entry for the H5MD reader (HDF5 C library included): the input bytes become a file that
// H5mdReader::open() must reject with an error value or accept, after which every frame
// offered (first and last) is read to the end in small batches. Any crash, sanitizer report
// or hang is a bug in the reader's validation. Seed corpus: small H5MD files written with h5py (see tests/test_h5md_reader.cpp).
// Built only with -DMDSTREAM_FUZZ=ON (clang).
// Run with -detect_leaks=0 and ASAN_OPTIONS=allocator_may_return_null=1: libhdf5 1.10.8
// itself leaks a few hundred bytes on some corrupted object headers and asks malloc for
// absurd sizes from corrupted metadata (H5C_protect), which it then handles as an error.
// mdstream's own HDF5 ids are all closed (checked with H5Fget_obj_count).
#include "fuzz_harness.h"
#include "h5md/h5md_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  mds::fuzz::run_reader(data, size, "mdstream_fuzz_h5md", mds::H5mdReader::open,
                        {.format = mds::InputFormat::h5md, .frames = {0, -1}, .batch = 97, .check_counts = false,
                         .detect_format = true, .property = "charge"});
  return 0;
}
