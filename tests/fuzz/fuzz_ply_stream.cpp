// Fuzz target: a binary PLY streamed from disk (open_ply_stream in preprocess/ply_reader.cpp), through
// a cache of its smallest size, against the in-memory PLY reader on the same bytes. Properties:
// malformed input throws InputError naming the file; every batch's arrays agree; where both readers
// accept the file, the stream hands over exactly the in-memory mesh's triangles, corner by corner.
#include <algorithm>
#include <cstring>
#include <string_view>

#include "tests/fuzz/fuzz_mesh.h"

namespace {

using strata::Mesh;
using strata::TriangleBatch;
using strata::fuzz::violated;

// The corners of the in-memory mesh, as the stream should give them (−0 as +0).
void expect_same_corners(const Mesh& mesh, const std::vector<TriangleBatch>& batches) {
    size_t corner = 0;
    for (const TriangleBatch& batch : batches)
        for (size_t i = 0; i < 3 * batch.triangle_count(); ++i, ++corner) {
            if (corner >= mesh.indices.size()) violated("the stream gave more triangles than the reader");
            const uint32_t v = mesh.indices[corner];
            for (int a = 0; a < 3; ++a) {
                const float want = mesh.positions[3 * size_t(v) + a] + 0.0f;
                if (std::memcmp(&want, &batch.positions[3 * i + a], 4) != 0) violated("a streamed position differs");
            }
            if (!batch.colors.empty() && std::memcmp(&mesh.colors[4 * size_t(v)], &batch.colors[4 * i], 4) != 0)
                violated("a streamed colour differs");
        }
    if (corner != mesh.indices.size()) violated("the stream gave fewer triangles than the reader");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    // Only a binary PLY streams: anything else is the in-memory reader's (fuzz_ply), and writing the
    // file would be most of the time spent on it.
    const std::string_view text(reinterpret_cast<const char*>(data), std::min<size_t>(size, 4096));
    if (!text.starts_with("ply") || text.find("binary_") == std::string_view::npos) return 0;
    const std::filesystem::path path = strata::fuzz::scratch_file("fuzz.ply", data, size);
    const std::string name = path.string();
    std::vector<std::string> warnings;
    std::vector<TriangleBatch> batches;
    bool streamed = false;
    try {
        auto source = strata::detail::open_ply_stream(path, name, nullptr, 1, warnings);
        if (!source) return 0;  // not a binary PLY with fixed-size vertices: the in-memory reader's
        source->for_each(
            [&](const TriangleBatch& batch) {
                const size_t n = batch.triangle_count();
                if (batch.positions.size() != 9 * n) violated("positions not 9 per triangle");
                if (!batch.normals.empty() && batch.normals.size() != 9 * n) violated("normals disagree");
                if (!batch.colors.empty() && batch.colors.size() != 12 * n) violated("colours disagree");
                if (!batch.uvs.empty() && batch.uvs.size() != 6 * n) violated("uvs disagree");
                for (float x : batch.positions)
                    if (!std::isfinite(x)) violated("a streamed position is not finite");
                if (batches.size() < 64) batches.push_back(batch);
            },
            {});
        streamed = batches.size() < 64;
    } catch (const strata::InputError& error) {
        strata::fuzz::expect_named(error.what(), name);
        return 0;
    }
    if (!streamed) return 0;
    const strata::Progress progress;
    const strata::detail::ReadInput input{path, name, reinterpret_cast<const char*>(data), size, progress};
    Mesh mesh;
    try {
        mesh = strata::detail::read_ply(input);
    } catch (const strata::InputError&) {
        return 0;  // e.g. a NaN in a vertex no face uses, which only the in-memory reader reads
    }
    expect_same_corners(mesh, batches);
    return 0;
}
