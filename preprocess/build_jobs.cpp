#include "preprocess/build_jobs.h"

#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <cstdio>

#include "preprocess/atomic_file.h"
#include "preprocess/block_step.h"
#include "preprocess/error_bound.h"
#include "preprocess/job_files.h"
#include "preprocess/leaf_cubes.h"
#include "preprocess/parallel.h"
#include "preprocess/run_spill.h"

namespace strata::build {
namespace {

std::string block_name(CubeKey block) {
    char name[24];
    std::snprintf(name, sizeof name, "%016" PRIx64, block);
    return name;
}

bool file_exists(const std::filesystem::path& path) {
    std::error_code ec;
    return std::filesystem::exists(path, ec);
}

// Removes a file, and its bytes from the build's count.
void remove_counted(const std::filesystem::path& path, DiskUsage& disk) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return;
    std::error_code ec;
    if (std::filesystem::remove(path, ec)) disk.remove(uint64_t(st.st_blocks) * 512);
}

bool in_stage(const Stage& stage, CubeKey block) {
    return std::binary_search(stage.blocks.begin(), stage.blocks.end(), block);
}

// The jobs of stage s − 1 whose files hold block `block`'s cubes at stage s, and every point listed
// within its reach (build_jobs.h).
std::vector<CubeKey> producers(const BuildPlan& plan, size_t stage, CubeKey block) {
    const Stage& before = plan.stages[stage - 1];
    const int64_t b[3] = {key_i(block), key_j(block), key_k(block)};
    const int64_t scale = stage == 1 ? 1 : 2;
    std::vector<CubeKey> keys;
    for (int64_t dk = -1; dk <= 1; ++dk)
        for (int64_t dj = -1; dj <= 1; ++dj)
            for (int64_t di = -1; di <= 1; ++di) {
                const int64_t i = scale * b[0] + di, j = scale * b[1] + dj, k = scale * b[2] + dk;
                if (i < 0 || j < 0 || k < 0) continue;
                const CubeKey key = make_key(uint64_t(i), uint64_t(j), uint64_t(k));
                if (in_stage(before, key)) keys.push_back(key);
            }
    return keys;
}

// Stage 0: a block's level-L cubes from its spilled triangles.
void leaf_job(const BuildPlan& plan, const WorkPaths& work, RunSpill& spill, CubeKey block, bool sole_runner, DiskUsage& disk) {
    LeafBlock leaves = leaf_block(spill.read(block), CornerLayout{plan.kept}, plan.frame);
    const std::vector<OpenEdge> odd = plan.settings.lock_boundary ? odd_edges(leaves.cubes) : std::vector<OpenEdge>();
    disk.add(write_cube_file(work.cube_file(0, block), std::move(leaves.cubes), plan.frame.max_level, leaves.border, odd, plan.frame));
    // The run's disk goes back at once only when no other process can be running the job again, and
    // reading the holes as its triangles.
    if (sole_runner) spill.release(block);
}

// Stage s ≥ 1: one block of level l simplified into level l − 1. Stage 1 of a build that locks the
// boundary first finds which of the block's level-L vertices lie on it (open_boundary.h); the flags then
// travel with the vertices' copies to every level.
uint64_t simplify_job(const BuildPlan& plan, const WorkPaths& work, size_t stage, CubeKey block, DiskUsage& disk) {
    const uint32_t level = plan.stages[stage].level;
    const bool find_boundary = stage == 1 && plan.settings.lock_boundary;
    std::vector<CubeRecord> records;
    std::vector<BorderEntry> listed;
    std::vector<OpenEdge> odd;
    for (CubeKey producer : producers(plan, stage, block)) {
        const CubeFile file(work.cube_file(stage - 1, producer));
        std::vector<CubeRecord> cubes = file.cubes_of(block);
        std::move(cubes.begin(), cubes.end(), std::back_inserter(records));
        const std::vector<BorderEntry> entries = file.listings();
        listed.insert(listed.end(), entries.begin(), entries.end());
        if (find_boundary) {
            const std::vector<OpenEdge> edges = file.odd_edges();
            odd.insert(odd.end(), edges.begin(), edges.end());
        }
    }
    const uint64_t listed_bytes = listed.size() * sizeof(BorderEntry) + odd.size() * sizeof(OpenEdge);
    std::sort(records.begin(), records.end(), [](const CubeRecord& a, const CubeRecord& b) { return a.key < b.key; });
    if (find_boundary) mark_boundary(records, std::move(odd));
    BlockOutput result;
    if (!records.empty()) {
        std::vector<const CubeRecord*> cubes;
        for (const CubeRecord& r : records) cubes.push_back(&r);
        result = simplify_block_cubes(cubes, level, block_border_table(listed, block, plan.frame, level), plan.frame,
                                      plan.settings, plan.header.flags);
    }
    // The cube file first: the payload file says the job is finished.
    disk.add(write_cube_file(work.cube_file(stage, block), std::move(result.parents), level - 1, result.border, {}, plan.frame));
    disk.add(write_payload_file(work.payload_file(stage, block), result.encoded));
    return listed_bytes;
}

std::string stage_name(const BuildPlan& plan, size_t stage) {
    return stage == 0 ? "level cubes" : "simplify level " + std::to_string(plan.stages[stage].level);
}

}  // namespace

std::filesystem::path WorkPaths::cube_file(size_t stage, CubeKey block) const {
    return stage_folder(stage) / (block_name(block) + ".cubes");
}

std::filesystem::path WorkPaths::payload_file(size_t stage, CubeKey block) const {
    return stage_folder(stage) / (block_name(block) + ".payloads");
}

bool job_finished(const WorkPaths& work, size_t stage, CubeKey block) {
    return file_exists(stage == 0 ? work.cube_file(0, block) : work.payload_file(stage, block));
}

bool stage_finished(const BuildPlan& plan, const WorkPaths& work, size_t stage, DiskUsage& disk) {
    if (!file_exists(work.stage_marker(stage))) {
        for (CubeKey block : plan.stages[stage].blocks)
            if (!job_finished(work, stage, block)) return false;
        AtomicOutputFile marker(work.stage_marker(stage));
        marker.commit();
    }
    if (stage == 0) {
        remove_counted(work.spill(), disk);
    } else {
        for (CubeKey block : plan.stages[stage - 1].blocks) remove_counted(work.cube_file(stage - 1, block), disk);
        std::error_code ec;
        std::filesystem::remove(work.stage_folder(stage - 1), ec);  // when it held no payloads (stage 0's)
    }
    return true;
}

std::vector<CubeKey> unfinished_jobs(const WorkPaths& work, size_t stage, const std::vector<CubeKey>& blocks) {
    std::vector<CubeKey> unfinished;
    if (file_exists(work.stage_marker(stage))) return unfinished;  // its jobs' files may be gone
    for (CubeKey block : blocks)
        if (!job_finished(work, stage, block)) unfinished.push_back(block);
    return unfinished;
}

JobStats run_jobs(const BuildPlan& plan, const WorkPaths& work, size_t stage, const std::vector<CubeKey>& blocks,
                  unsigned threads, bool sole_runner, DiskUsage& disk, const Progress& progress) {
    std::vector<CubeKey> todo = unfinished_jobs(work, stage, blocks);
    std::error_code ec;
    std::filesystem::create_directories(work.stage_folder(stage), ec);
    if (ec) throw std::runtime_error(work.dir.string() + ": cannot create " + work.stage_folder(stage).filename().string() +
                                     " (" + ec.message() + ")");
    std::unique_ptr<RunSpill> spill;
    if (stage == 0 && !todo.empty()) {
        try {
            ByteReader index{plan.spill_index, work.plan().string() + " (the spill's index)"};
            spill = std::make_unique<RunSpill>(work.spill(), disk, index);
        } catch (const std::runtime_error&) {
            // Gone because other processes finished these jobs, and with them the stage?
            if (!std::all_of(todo.begin(), todo.end(), [&](CubeKey b) { return job_finished(work, 0, b); })) throw;
            todo.clear();
        }
    }
    const std::string name = stage_name(plan, stage);
    std::atomic<uint64_t> done{0}, border_bytes{0};
    parallel_for(todo.size(), threads, [&](size_t j, unsigned worker) {
        progress.check();
        try {
            if (stage == 0) {
                leaf_job(plan, work, *spill, todo[j], sole_runner, disk);
            } else {
                const uint64_t bytes = simplify_job(plan, work, stage, todo[j], disk);
                for (uint64_t most = border_bytes.load(); bytes > most && !border_bytes.compare_exchange_weak(most, bytes);) {
                }
            }
        } catch (const std::runtime_error&) {
            // Another process ran the job too, finished it first and, finding its stage complete, removed
            // the files this run was reading: the job is done all the same.
            if (!job_finished(work, stage, todo[j])) throw;
        }
        const uint64_t finished = ++done;
        if (worker == 0) progress(name, double(finished), double(todo.size()), "blocks");
    });
    progress(name, double(todo.size()), double(todo.size()), "blocks");
    return JobStats{border_bytes.load(), todo.size()};
}

Assembly assemble(const BuildPlan& plan, const WorkPaths& work, const std::filesystem::path& output, const Progress& progress) {
    const Frame& f = plan.frame;
    const uint32_t L = f.max_level;
    Assembly result;
    for (uint32_t l = L + 1; l-- > 0;) result.levels.push_back(LevelStats{l});
    HlodWriter writer(output);
    std::vector<CubeErrors> errors;
    auto add = [&](const EncodedCube& e) {
        writer.add_cube(e.node, e.payload);
        errors.push_back({e.node.level, e.node.i, e.node.j, e.node.k, e.node.error, e.coverage});
        LevelStats& stats = result.levels[L - e.node.level];
        stats.cubes++, stats.vertices += e.node.vertex_count, stats.triangles += e.node.triangle_count;
        stats.bytes += e.payload.size();
    };
    uint64_t done = 0;
    for (size_t stage = 1; stage < plan.stages.size(); ++stage)
        for (CubeKey block : plan.stages[stage].blocks) {
            progress.check();
            for (const EncodedCube& e : read_payload_file(work.payload_file(stage, block))) add(e);
            progress("write", double(++done), double(plan.job_count()), "blocks");
        }
    // The root: level 0's one cube, made by the last stage's one job, and every point level 0 lists.
    const size_t last = plan.stages.size() - 1;
    // With L = 0 no simplifying stage found the boundary: the leaf job's one block is the whole model.
    const bool find_boundary = last == 0 && plan.settings.lock_boundary;
    std::vector<CubeRecord> roots;
    std::vector<BorderEntry> listed;
    std::vector<OpenEdge> odd;
    for (CubeKey block : plan.stages[last].blocks) {
        const CubeFile file(work.cube_file(last, block));
        for (CubeRecord& c : file.cubes_of(0)) roots.push_back(std::move(c));
        const std::vector<BorderEntry> entries = file.listings();
        listed.insert(listed.end(), entries.begin(), entries.end());
        if (find_boundary) odd = file.odd_edges();
    }
    if (roots.size() != 1) throw std::logic_error("the build made " + std::to_string(roots.size()) + " root cubes");
    if (find_boundary) mark_boundary(roots, std::move(odd));
    std::vector<PositionBits> boundary;  // no level removes a boundary point: the root's are all of them
    for (uint32_t v = 0; v < roots.front().boundary.size(); ++v)
        if (roots.front().boundary[v]) boundary.push_back(position_bits(&roots.front().positions[3 * size_t(v)]));
    std::sort(boundary.begin(), boundary.end());
    result.boundary_points = uint64_t(std::unique(boundary.begin(), boundary.end()) - boundary.begin());
    add(encode_root(roots.front(), BorderTable(std::move(listed)), f, plan.header.flags));
    const std::vector<float> bounds = final_bounds(errors, f, plan.settings.lock_boundary);
    for (size_t c = 0; c < bounds.size(); ++c) {
        writer.set_error(c, bounds[c]);
        result.error_q = std::max(result.error_q, round_up(bounds[c] / f.cube_size(errors[c].level)));
    }

    HlodHeader header = plan.header;
    header.error_q = result.error_q;
    header.input_vertices = result.levels.front().vertices;
    writer.finish(header);
    std::error_code ec;
    result.output_bytes = std::filesystem::file_size(output, ec);
    return result;
}

}  // namespace strata::build
