// A build's plan (hlod_builder.h): what the first two passes over the input decided, saved in the work
// folder so that the jobs after them can run in other processes, on other machines, or after a kill.
// It records the settings the output depends on (a resumed build with others is refused, naming the
// setting), the inputs as they were (a changed input is refused), the frame and the header, where the
// triangle spill keeps each block's triangles, and the job list: stage 0 makes each level-L block's
// cubes from the spill; stage s ≥ 1 simplifies the blocks of level L − s + 1. A stage's jobs start when
// the stage before has finished.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "preprocess/build_cubes.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"
#include "preprocess/triangle_source.h"

namespace strata::build {

// An input file as the build found it; a resumed build checks its inputs are still these.
struct InputRecord {
    std::string path;  // absolute
    uint64_t size = 0;
    int64_t modified_ns = 0;
    bool operator==(const InputRecord&) const = default;
};

// The files' records now. Throws InputError naming a file that cannot be examined.
std::vector<InputRecord> record_inputs(const std::vector<std::filesystem::path>& files);

struct Stage {
    uint32_t level = 0;               // the level of the cubes its jobs read (stage 0: of those it makes)
    uint64_t first_job = 0;           // its jobs' numbers are first_job … first_job + blocks.size() − 1
    std::vector<CubeKey> blocks;      // in key order, a job each
};

struct BuildPlan {
    BuildSettings settings;  // as asked for; only what changes the output counts (settings_differ)
    std::vector<InputRecord> inputs;
    Frame frame{};
    HlodHeader header;       // all but what the jobs find (ε_q, input_vertices, node_count)
    AttributeSet kept;       // the attributes the corners carry
    std::vector<std::string> notes;
    std::vector<uint8_t> spill_index;  // RunSpill::save_index
    std::vector<Stage> stages;
    // What the planning process measured, for the report of a build run in one go.
    double read_seconds = 0, spill_seconds = 0;
    uint64_t spill_memory_bytes = 0, source_memory_bytes = 0;

    uint64_t job_count() const { return stages.empty() ? 0 : stages.back().first_job + stages.back().blocks.size(); }
    // The stage of job `job` (< job_count()).
    size_t stage_of(uint64_t job) const;
};

// Fills plan.stages from stage 0's blocks (the spill's): stage 1 simplifies those, and each later
// stage every block a parent of the stage before's cubes may lie in.
void plan_stages(BuildPlan& plan, std::vector<CubeKey> leaf_blocks);

// The first setting the output depends on (levels, block, ratio, σ0, error, leaf size, the boundary's
// lock) whose value differs, as "--ratio 0.25 (now 0.3)"; empty when none does.
std::string settings_differ(const BuildSettings& planned, const BuildSettings& now);

// Writes `path` whole (temporary file, then rename); throws std::runtime_error naming it.
void save_plan(const BuildPlan& plan, const std::filesystem::path& path);
// Throws DamagedWork naming the file when it is short or damaged, std::runtime_error when it cannot be
// opened.
BuildPlan load_plan(const std::filesystem::path& path);

// The job list for people and schedulers: a line per stage, "stage LEVEL FIRST LAST" and what it does.
std::string describe_jobs(const BuildPlan& plan);

}  // namespace strata::build
