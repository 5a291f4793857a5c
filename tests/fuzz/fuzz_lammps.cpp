// libFuzzer entry point for the LAMMPS text dump reader: the input bytes become a file
// (plain, or gzip/zstd when they carry those magic bytes) which is opened at the first
// and at the last frame and read to the end in small batches, and whose frames are listed (list_frames) and each
// opened at its mark. Errors are fine; crashes,
// sanitizer reports and hangs are bugs.
#include "fuzz_harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  mds::fuzz::run_reader(data, size, "fuzz_lammps", mds::open_lammps_reader, {.property = "c_pe"});
  mds::fuzz::run_frame_list("fuzz_lammps", mds::open_lammps_reader, mds::InputFormat::lammps);
  return 0;
}
