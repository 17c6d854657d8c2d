// The HLOD builder (DESIGN.md §2, thesis 000 chapter 3): partitions a mesh into the level-L octree,
// simplifies block by block down to level 0 keeping every vertex's parent, and writes the .hlod.
#pragma once

#include "preprocess/mesh.h"
#include "preprocess/progress.h"

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
    uint64_t output_bytes = 0;
    uint64_t temp_bytes = 0;  // peak bytes of the temporary cube files (not counting the payload spool)
    // Wall seconds per stage, for benchmarks: partition (level L's cubes), simplify (each level's
    // blocks, normals and encoding), write (the root and the file's assembly).
    double partition_seconds = 0, simplify_seconds = 0, write_seconds = 0;
};

// Throws InputError naming the first setting out of range (checked before any input is read, so a
// command line can tell wrong arguments from bad input).
void check_settings(const BuildSettings& settings);

// Consumes the mesh (its arrays become level L), which must be welded as read_mesh returns it: a
// position repeats only on vertices whose attributes differ. Throws InputError for input it cannot build
// (empty, flat to a point, settings out of range), Cancelled when progress.cancel is raised, and
// std::runtime_error for output failures; in every case no output file is left behind.
BuildReport build_hlod(Mesh&& mesh, const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress = {});

// What builds of `output` that were killed left behind: their work folders (in `temp_dir`, or beside
// the output when it is empty) and the writer's temporary files beside the output. A running build's
// are kept. Removes them and returns their paths.
std::vector<std::filesystem::path> remove_build_leftovers(const std::filesystem::path& output,
                                                          const std::filesystem::path& temp_dir);

}  // namespace strata
