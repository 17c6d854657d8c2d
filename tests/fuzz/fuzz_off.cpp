// Fuzz target: the OFF reader (preprocess/off_reader.cpp), in memory, then weld().
#include "tests/fuzz/fuzz_mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    strata::fuzz::read_mesh_bytes(strata::detail::read_off, data, size, "fuzz.off");
    return 0;
}
