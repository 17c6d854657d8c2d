// The HLOD builder (DESIGN.md §2, thesis 000 chapter 3): partitions a mesh into the level-L octree,
// simplifies block by block down to level 0 keeping every vertex's parent, and writes the .hlod.
//
// A build is a plan (two passes over the input: the frame, then every triangle spilled to its block),
// then jobs, a block each, stage by stage from level L up (build_jobs.h), then the assembly of their
// payloads into the file. Every step leaves its results as whole files in a work folder and reads
// only those, so a killed build resumes from its finished jobs, and the jobs can run on many machines
// (plan_build, run_build_jobs, assemble_build); either way the bytes equal those of one uninterrupted
// build.
#pragma once

#include "preprocess/mesh.h"
#include "preprocess/progress.h"
#include "preprocess/triangle_source.h"

#include <filesystem>
#include <functional>
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
    // For a mesh to be embedded in a terrain: its open boundary (the edges an odd number of triangles
    // use, by position: once, where the mesh is a surface) is never simplified, and each of its vertices
    // is stored on level 0's lattice at every level, so every level draws the finest level's boundary
    // to the bit (FORMAT.md §6 "Locked boundary").
    bool lock_boundary = false;
    std::filesystem::path temp_dir;  // the build's temporary files; empty: beside the output
    // Bytes the build may hold for its buffers (a quarter for the vertex cache of streamed inputs, a
    // quarter, at most 256 MiB, for the triangle spill's and the border listings' buffers); 0: a quarter
    // of physical memory. Never changes a byte of the output.
    uint64_t memory = 0;
    // Go on from what a killed or failed build of the same output left, if anything (build_hlod).
    bool resume = false;
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
    uint64_t temp_bytes = 0;  // peak bytes of the work folder's files (not counting the writer's payload spool)
    uint64_t jobs = 0, jobs_resumed = 0;  // the plan's jobs, and how many a killed build had finished
    bool resumed = false;                 // the plan came from an earlier, killed build
    bool already_complete = false;        // --resume found the output complete and nothing to resume
    uint64_t boundary_points = 0;  // with lock_boundary: the open boundary's points (seam copies as one)
    // Wall seconds per stage, for benchmarks: read (the first pass over the input: extent, counts),
    // partition (the second pass, and level L's cubes), simplify (each level's
    // blocks, normals and encoding), write (the root and the file's assembly).
    double read_seconds = 0, partition_seconds = 0, simplify_seconds = 0, write_seconds = 0;
    // A terrain's textures (section TXTR): texels along a cube's texture, their compressed bytes and
    // the wall seconds spent on them (counted in write_seconds too); 0 without.
    uint32_t texture_size = 0;
    uint64_t texture_bytes = 0;
    double texture_seconds = 0;
    // Terrains: the finest level's height lattice (metres); its vertices are within half of it of the raster.
    double height_quantum = 0;
};

// Throws InputError naming the first setting out of range (checked before any input is read, so a
// command line can tell wrong arguments from bad input).
void check_settings(const BuildSettings& settings);

// A build's input: the sources (open_sources()), each read twice, and which attributes the model
// keeps (common_attributes()).
struct BuildInput {
    std::vector<std::unique_ptr<TriangleSource>> sources;
    ModelAttributes model;
};
// Opens the input; a build calls it only when it must read the input (not when it resumes a build
// whose plan was made).
using OpenInput = std::function<BuildInput()>;

// Builds `output` from the input the files hold. The triangles are welded as weld() would: corners
// equal in position and every kept attribute are one vertex, and triangles with two corners at one
// position are dropped. The work folder is temp_folder()/OUT.build, locked while the build runs.
// With settings.resume, goes on from a killed or failed build's work folder (refusing, by name, a
// setting that changes the output, or an input that changed); with nothing to resume, builds from
// the start, or, when the output exists, leaves it and reports already_complete. Without it, a work
// folder left by a killed build is refused, saying so. Throws InputError for input it cannot build
// (empty, flat to a point, settings out of range), Cancelled when progress.cancel is raised, and
// std::runtime_error for output failures; in every case no output file is left behind. The work
// folder is removed on success, on Cancelled and on bad input; kept after other failures, for --resume.
BuildReport build_hlod(const OpenInput& open, const std::vector<std::filesystem::path>& files,
                       const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress = {});

// The same from an input already opened (no files are recorded: a resumed build does not check them).
BuildReport build_hlod(BuildInput input, const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress = {});

// The same from a mesh in memory (its indices in range), which it consumes.
BuildReport build_hlod(Mesh&& mesh, const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress = {});

// ---- a build split into jobs, for a cluster's scheduler --------------------------------------------

// strata build --plan DIR: the plan, in `dir` (created; it must not hold anything yet). Returns the
// job list (also written to DIR/jobs.txt): a line per stage with its range of job numbers.
std::string plan_build(const OpenInput& open, const std::vector<std::filesystem::path>& files,
                       const std::filesystem::path& dir, const BuildSettings& settings, const std::string& source_name,
                       const Progress& progress = {});

struct JobRunReport {
    uint64_t run = 0, already_finished = 0;
};
// strata build --run-blocks DIR FIRST-LAST: runs jobs first … last (inclusive) that have not finished.
// Throws InputError for a range outside the plan's jobs, or for jobs whose stage before has not finished.
JobRunReport run_build_jobs(const std::filesystem::path& dir, uint64_t first, uint64_t last, int threads,
                            const Progress& progress = {});

// strata build --assemble DIR -o OUT: writes the model once every job has finished (InputError
// otherwise, naming the first stage that has not), then removes `dir`.
BuildReport assemble_build(const std::filesystem::path& dir, const std::filesystem::path& output,
                           const Progress& progress = {});

// The output's folder must take a file before a build spends hours on it (the writer only opens the
// output at the end). Throws std::runtime_error naming the output.
void check_output_folder(const std::filesystem::path& output);

// The folder a build of `output` keeps its work folder in: `temp_dir`, or else the output's own
// folder ("." for a bare file name).
std::filesystem::path temp_folder(const std::filesystem::path& output, const std::filesystem::path& temp_dir);

// The bytes the work folder of a killed or failed build of `output` takes on disk (0 when there is none).
uint64_t leftover_bytes(const std::filesystem::path& output, const std::filesystem::path& temp_dir);

// What builds of `output` that were killed or failed left behind: the work folder (in `temp_dir`, or
// beside the output when it is empty) unless a running build holds it, and the writer's temporary
// files of processes that are gone, beside the output. Removes them and returns their paths.
std::vector<std::filesystem::path> remove_build_leftovers(const std::filesystem::path& output,
                                                          const std::filesystem::path& temp_dir);

}  // namespace strata
