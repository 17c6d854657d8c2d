// The mesh fuzz targets: one format's reader on the input bytes, in memory, then weld() as read_mesh()
// does. Properties: malformed input throws InputError naming the file; accepted input gives a mesh
// whose arrays agree and whose triangles name existing vertices (what the builder relies on).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "preprocess/mesh_io.h"
#include "preprocess/mesh_readers.h"
#include "tests/fuzz/fuzz_support.h"

namespace strata::fuzz {

inline void check_mesh(const Mesh& mesh) {
    const size_t n = mesh.vertex_count();
    if (mesh.positions.size() != 3 * n) violated("positions not a multiple of 3");
    if (!mesh.normals.empty() && mesh.normals.size() != 3 * n) violated("normals disagree with positions");
    if (!mesh.colors.empty() && mesh.colors.size() != 4 * n) violated("colours disagree with positions");
    if (!mesh.uvs.empty() && mesh.uvs.size() != 2 * n) violated("uvs disagree with positions");
    if (mesh.indices.size() % 3 != 0) violated("indices not a multiple of 3");
    for (uint32_t index : mesh.indices)
        if (index >= n) violated("index " + std::to_string(index) + " past " + std::to_string(n) + " vertices");
}

// `path` is what the reader is told the file is (an OBJ looks for its .mtl beside it).
inline void read_mesh_bytes(Mesh (*reader)(const detail::ReadInput&), const uint8_t* data, size_t size,
                            const std::filesystem::path& path) {
    if (size == 0) return;  // read_mesh() refuses an empty file before any reader sees it
    const Progress progress;
    const detail::ReadInput input{path, path.string(), reinterpret_cast<const char*>(data), size, progress};
    try {
        Mesh mesh = reader(input);
        weld(mesh);
        check_mesh(mesh);
    } catch (const InputError& error) {
        expect_named(error.what(), input.name);
    }
}

}  // namespace strata::fuzz
