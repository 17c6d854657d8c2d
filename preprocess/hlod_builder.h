// The HLOD builder (DESIGN.md §2, thesis 000 chapter 3): partitions a mesh into the level-L octree,
// simplifies block by block down to level 0 keeping every vertex's parent, and writes the .hlod.
#pragma once

#include "preprocess/mesh.h"
#include "preprocess/progress.h"
#include "preprocess/triangle_source.h"

#include <filesystem>
#include <string>
#include <vector>

namespace strata {

struct BuildSettings {
    int levels = -1;          // L; −1 picks it so a leaf holds about leaf_triangles
    int block = 4;            // n: cubes per block side, a multiple of 4
    float ratio = 0.25f;      // triangles kept per level
    float sigma0 = 0.25f;     // the least σ0; raised to what the data's edges need
    float error = -1;         // ε_q: stop a level's collapses at ε_q·s_l; −1 for no limit
    int threads = 0;          // 0: every core
    int leaf_triangles = 4096;
    std::filesystem::path temp_dir;  // the build's temporary files; empty: beside the output
    // Bytes the build may hold for its buffers (a quarter for the vertex cache of streamed inputs, a
    // quarter, at most 256 MiB, for the triangle spill's and the border listings' buffers); 0: a quarter
    // of physical memory. Never changes a byte of the output.
    uint64_t memory = 0;
};

struct LevelStats {
    uint32_t level = 0;
    uint64_t cubes = 0, vertices = 0, triangles = 0, bytes = 0;
};

struct BuildReport {
    uint32_t max_level = 0;
    float sigma0 = 0;
    float error_q = 0;
    std::vector<LevelStats> levels;  // finest first
    std::vector<std::string> notes;  // choices the builder made that the user should know of
    uint64_t input_triangles = 0;  // proper ones (degenerate triangles are dropped)
    uint64_t output_bytes = 0;
    uint64_t spill_memory_bytes = 0;   // the most the triangle spill buffered
    uint64_t source_memory_bytes = 0;  // the most one input held (its mesh, or its vertex cache)
    uint64_t border_bytes = 0;         // the most one level's border listings took
    uint64_t temp_bytes = 0;  // peak bytes of the temporary cube files (not counting the payload spool)
    // Wall seconds per stage, for benchmarks: read (the first pass over the input: extent, counts),
    // partition (the second pass, and level L's cubes), simplify (each level's
    // blocks, normals and encoding), write (the root and the file's assembly).
    double read_seconds = 0, partition_seconds = 0, simplify_seconds = 0, write_seconds = 0;
};

// Throws InputError naming the first setting out of range (checked before any input is read, so a
// command line can tell wrong arguments from bad input).
void check_settings(const BuildSettings& settings);

// Builds from the sources (open_sources()), reading each twice; `model` says which attributes the
// model keeps (common_attributes()). The triangles are welded as weld() would: corners equal in
// position and every kept attribute are one vertex, and triangles with two corners at one position
// are dropped. Throws InputError for input it cannot build
// (empty, flat to a point, settings out of range), Cancelled when progress.cancel is raised, and
// std::runtime_error for output failures; in every case no output file is left behind.
BuildReport build_hlod(const std::vector<std::unique_ptr<TriangleSource>>& sources, const ModelAttributes& model,
                       const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress = {});

// The same from a mesh in memory (its indices in range), which it consumes.
BuildReport build_hlod(Mesh&& mesh, const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress = {});

// The folder a build of `output` keeps its temporary files in: `temp_dir`, or else the output's own
// folder ("." for a bare file name).
std::filesystem::path temp_folder(const std::filesystem::path& output, const std::filesystem::path& temp_dir);

// What builds of `output` that were killed left behind: their work folders (in `temp_dir`, or beside
// the output when it is empty) and the writer's temporary files beside the output. A running build's
// are kept. Removes them and returns their paths.
std::vector<std::filesystem::path> remove_build_leftovers(const std::filesystem::path& output,
                                                          const std::filesystem::path& temp_dir);

}  // namespace strata
