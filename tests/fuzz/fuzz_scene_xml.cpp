// libFuzzer target for the scene XML reader (load_scene); the work is in harness.h.
#include "fuzz/harness.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) { return iris::fuzz::scene_xml_one(data, size); }
