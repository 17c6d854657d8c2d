// Fuzz target: the OBJ reader (preprocess/obj_reader.cpp) with the .mtl it names. The input is the OBJ
// text, optionally followed by a NUL byte and the text of "fuzz.mtl", which is written beside the OBJ
// (the reader finds a material library by path only); without a NUL there is no .mtl.
#include <cstring>
#include <system_error>

#include "tests/fuzz/fuzz_mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace strata::fuzz;
    const auto* nul = static_cast<const uint8_t*>(std::memchr(data, 0, size));
    const std::filesystem::path mtl = ScratchDir::path() / "fuzz.mtl";
    if (nul) {
        scratch_file("fuzz.mtl", nul + 1, size_t(data + size - (nul + 1)));
    } else {
        std::error_code ignored;
        std::filesystem::remove(mtl, ignored);
    }
    const size_t obj_size = nul ? size_t(nul - data) : size;
    read_mesh_bytes(strata::detail::read_obj, data, obj_size, ScratchDir::path() / "fuzz.obj");
    return 0;
}
