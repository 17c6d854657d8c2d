// Fuzz target: the PLY reader (preprocess/ply_reader.cpp), in memory, then weld().
#include "tests/fuzz/fuzz_mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    strata::fuzz::read_mesh_bytes(strata::detail::read_ply, data, size, "fuzz.ply");
    return 0;
}
