// libFuzzer target for the PLY and Mitsuba serialized mesh readers; the work is in harness.h.
#include "fuzz/harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) { return iris::fuzz::mesh_one(data, size); }
