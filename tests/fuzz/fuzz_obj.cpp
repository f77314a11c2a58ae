// libFuzzer target for the OBJ reader (parse_obj); the work is in harness.h.
#include "fuzz/harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) { return iris::fuzz::obj_one(data, size); }
