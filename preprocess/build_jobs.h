// The jobs of a planned build (build_plan.h) and the assembly of their results into the .hlod. A job
// reads only files of the work folder and writes only its own, whole or not at all (job_files.h), and
// its bytes depend on nothing but the plan: so jobs may run in any process, be killed and run again,
// or run twice, and the model comes out the same.
//
// Stage 0's job for block B reads B's triangles from the spill and writes B's level-L cubes (and, when
// the build locks the boundary, the edges B uses an odd number of times: open_boundary.h). Stage
// s ≥ 1's job for level-l block B reads B's cubes and the points listed near B from the jobs of stage
// s − 1 that made cubes within one cube of B (for s = 1 the 27 blocks around B; after that, per axis,
// blocks 2B − 1 … 2B + 1 of level l + 1, since the block grid is offset by half a block), simplifies
// them (block_step.h), and writes the level-(l − 1) cubes they became and B's encoded payloads.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "preprocess/build_plan.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/progress.h"
#include "preprocess/scratch_file.h"

namespace strata::build {

// Where a build's files lie in its work folder.
struct WorkPaths {
    std::filesystem::path dir;

    std::filesystem::path plan() const { return dir / "plan"; }
    std::filesystem::path job_list() const { return dir / "jobs.txt"; }
    std::filesystem::path spill() const { return dir / "triangles.spill"; }
    std::filesystem::path stage_folder(size_t stage) const { return dir / ("stage-" + std::to_string(stage)); }
    std::filesystem::path stage_marker(size_t stage) const { return dir / ("stage-" + std::to_string(stage) + ".done"); }
    std::filesystem::path cube_file(size_t stage, CubeKey block) const;
    std::filesystem::path payload_file(size_t stage, CubeKey block) const;
};

// A job is finished when its last file exists: its payloads (stage 0: its cubes). Once its stage is
// marked finished (stage_finished), that file may have been removed.
bool job_finished(const WorkPaths& work, size_t stage, CubeKey block);

// Whether every job of the stage has finished. The first call that finds so marks the stage and
// removes what only its jobs read (stage 0: the spill; stage s: stage s − 1's cube files).
bool stage_finished(const BuildPlan& plan, const WorkPaths& work, size_t stage, DiskUsage& disk);

// The jobs of `stage` among `blocks` that have not finished, in their order: none once the stage is
// marked finished (its jobs' files may have been removed since).
std::vector<CubeKey> unfinished_jobs(const WorkPaths& work, size_t stage, const std::vector<CubeKey>& blocks);

struct JobStats {
    uint64_t border_bytes = 0;  // the most listings one job held
    uint64_t run = 0;           // the jobs it found unfinished and ran
};

// Runs the unfinished jobs of `stage` among `blocks` (in the stage's order) on `threads` threads; the
// stage before must have finished. `sole_runner`: no other process runs this build's jobs (it holds
// the work folder's lock), so stage 0 may give the spill's disk back block by block. Throws Cancelled,
// or std::runtime_error naming a file the disk refused.
JobStats run_jobs(const BuildPlan& plan, const WorkPaths& work, size_t stage, const std::vector<CubeKey>& blocks,
                  unsigned threads, bool sole_runner, DiskUsage& disk, const Progress& progress);

struct Assembly {
    std::vector<LevelStats> levels;  // finest first
    float error_q = 0;
    uint64_t output_bytes = 0;
    uint64_t boundary_points = 0;  // a locked boundary's points (the root holds them all)
};

// Writes the model from the finished jobs' payloads and the root (encoded here, from the last stage's
// cubes), through a temporary file renamed into place.
Assembly assemble(const BuildPlan& plan, const WorkPaths& work, const std::filesystem::path& output, const Progress& progress);

}  // namespace strata::build
