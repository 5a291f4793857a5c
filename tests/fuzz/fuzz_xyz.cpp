// libFuzzer entry point for the XYZ / extended XYZ reader (see fuzz_lammps.cpp).
#include "fuzz_harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  mds::fuzz::run_reader(data, size, "fuzz_xyz", mds::open_xyz_reader, {.property = "charge", .color = true});
  mds::fuzz::run_frame_list("fuzz_xyz", mds::open_xyz_reader, mds::InputFormat::xyz);
  return 0;
}
