// libFuzzer target for the HDF5 stage-file readers; the work is in harness.h.
#include "fuzz/harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) { return iris::fuzz::stage_hdf5_one(data, size); }
