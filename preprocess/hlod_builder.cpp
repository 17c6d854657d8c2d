#include "preprocess/hlod_builder.h"

#include "preprocess/block_step.h"
#include "preprocess/border_runs.h"
#include "preprocess/border_table.h"
#include "preprocess/build_cubes.h"
#include "preprocess/byte_size.h"
#include "preprocess/cube_store.h"
#include "preprocess/hlod_format.h"
#include "preprocess/input_scan.h"
#include "preprocess/leaf_cubes.h"
#include "preprocess/parallel.h"
#include "preprocess/triangle_spill.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>

namespace strata {
namespace {

using build::CubeKey;
using build::CubeRecord;
using build::Frame;

// The 16-bit lattice holds a cell plus an overhang below half a cell on each side.
constexpr float kMaxSigma0 = 0.45f;
constexpr int kMaxLevels = 15;  // keeps the lattice integer q = 2^15·cell + … within 31 bits
constexpr uint64_t kLeastMemory = uint64_t(16) << 20;
constexpr uint64_t kMostSpillBuffer = uint64_t(256) << 20;
// A build of OUT keeps its temporary files in OUT<kWorkMarker>PID (WorkFolder, remove_build_leftovers).
constexpr std::string_view kWorkMarker = ".build-";

// Adds the wall time of its scope to a counter.
class StageTimer {
public:
    explicit StageTimer(double& total) : total_(total), start_(std::chrono::steady_clock::now()) {}
    ~StageTimer() { total_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

private:
    double& total_;
    std::chrono::steady_clock::time_point start_;
};

// ---- simplifying level by level ---------------------------------------------------------

// The keys of a level's cubes grouped by block (blocks in key order, cubes in key order within one).
std::vector<std::vector<CubeKey>> group_blocks(const std::vector<CubeKey>& keys, const Frame& f) {
    std::vector<CubeKey> order = keys;
    std::stable_sort(order.begin(), order.end(), [&](CubeKey a, CubeKey b) { return f.block_of(a) < f.block_of(b); });
    std::vector<std::vector<CubeKey>> blocks;
    for (size_t i = 0; i < order.size(); ++i) {
        if (i == 0 || f.block_of(order[i]) != f.block_of(order[i - 1])) blocks.emplace_back();
        blocks.back().push_back(order[i]);
    }
    return blocks;
}

// The payloads of one level as blocks finish them, from several threads.
class LevelWriter {
public:
    LevelWriter(HlodWriter& writer, LevelStats& stats, const Frame& f) : writer_(writer), stats_(stats), f_(f) {}
    void add(const build::EncodedCube& e) {
        std::lock_guard lock(mutex_);
        writer_.add_cube(e.node, e.payload);
        stats_.cubes++, stats_.vertices += e.node.vertex_count, stats_.triangles += e.node.triangle_count;
        stats_.bytes += e.payload.size();
        relative_error_ = std::max(relative_error_, float(e.node.error / f_.cube_size(e.node.level)));
    }
    float relative_error() const { return relative_error_; }  // ε_q's share of this level

private:
    std::mutex mutex_;
    HlodWriter& writer_;
    LevelStats& stats_;
    const Frame& f_;
    float relative_error_ = 0;
};

// Simplifies level l block by block into level l−1 (`next`), writing level l's cubes; the points
// level l's cubes list are in `listed`, those level l−1's list go to `next_listed`. Only the blocks in
// flight are in memory.
void simplify_level(build::CubeStore& level, const build::RunSpill& listed, uint32_t l, const Frame& f,
                    const BuildSettings& s, uint32_t flags, LevelWriter& out, build::CubeStore& next,
                    build::RunSpill& next_listed, const Progress& progress) {
    const std::vector<std::vector<CubeKey>> blocks = group_blocks(level.keys(), f);
    std::atomic<uint64_t> done{0};
    const double total = double(level.triangles());
    const std::string stage = "simplify level " + std::to_string(l);
    parallel_for(blocks.size(), resolve_thread_count(s.threads), [&](size_t b, unsigned worker) {
        progress.check();
        std::vector<CubeRecord> records;
        std::vector<const CubeRecord*> cubes;
        uint64_t triangles = 0;
        for (CubeKey key : blocks[b]) records.push_back(level.get(key)), triangles += records.back().triangle_count();
        for (const CubeRecord& r : records) cubes.push_back(&r);
        const build::BorderTable border = build::block_border_table(listed, f.block_of(blocks[b].front()), f, l);
        build::BlockOutput result = build::simplify_block_cubes(cubes, l, border, f, s, flags);
        for (const build::EncodedCube& e : result.encoded) out.add(e);
        for (const CubeRecord& parent : result.parents) next.put(parent);
        build::append_listings(result.border, next_listed);
        const uint64_t finished = done += triangles;
        if (worker == 0) progress(stage, double(finished), total, "tri");
    });
    next_listed.finish();
    progress(stage, total, total, "tri");
}

std::filesystem::path folder_or_here(const std::filesystem::path& folder) {
    return folder.empty() ? std::filesystem::path(".") : folder;
}

}  // namespace

std::filesystem::path temp_folder(const std::filesystem::path& output, const std::filesystem::path& temp_dir) {
    return folder_or_here(temp_dir.empty() ? output.parent_path() : temp_dir);
}

namespace {

// Where the builder keeps its temporary files: a folder of its own, "OUT.hlod.build-PID", removed with
// everything in it.
class WorkFolder {
public:
    WorkFolder(const std::filesystem::path& output, const std::filesystem::path& temp) {
        path_ = temp_folder(output, temp) /
                (output.filename().string() + std::string(kWorkMarker) + std::to_string(::getpid()));
        std::error_code ec;
        std::filesystem::create_directories(path_, ec);
        if (ec) throw std::runtime_error(path_.parent_path().string() + ": cannot create the build's temporary folder (" + ec.message() + ")");
    }
    ~WorkFolder() {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

private:
    std::filesystem::path path_;
};

}  // namespace

std::vector<std::filesystem::path> remove_build_leftovers(const std::filesystem::path& output,
                                                          const std::filesystem::path& temp_dir) {
    const std::string name = output.filename().string();
    // "<name><marker><pid>" plus the given suffix, for a process that is gone.
    auto left_by_dead_build = [&](const std::string& entry, std::string_view marker, std::string_view suffix) {
        const std::string prefix = name + std::string(marker);
        if (entry.size() <= prefix.size() + suffix.size() || entry.compare(0, prefix.size(), prefix) != 0 ||
            entry.compare(entry.size() - suffix.size(), suffix.size(), suffix) != 0)
            return false;
        const std::string pid = entry.substr(prefix.size(), entry.size() - prefix.size() - suffix.size());
        if (pid.empty() || pid.size() > 9 || !std::all_of(pid.begin(), pid.end(), ::isdigit)) return false;
        return ::kill(pid_t(std::stol(pid)), 0) != 0 && errno == ESRCH;
    };
    std::vector<std::filesystem::path> removed;
    auto sweep = [&](const std::filesystem::path& folder, auto&& matches) {
        std::error_code ec;
        for (const auto& e : std::filesystem::directory_iterator(folder_or_here(folder), ec))
            if (matches(e.path().filename().string())) {
                std::filesystem::remove_all(e.path(), ec);
                removed.push_back(e.path());
            }
    };
    sweep(temp_folder(output, temp_dir),
          [&](const std::string& entry) { return left_by_dead_build(entry, kWorkMarker, ""); });
    sweep(output.parent_path(), [&](const std::string& entry) {
        return left_by_dead_build(entry, HlodWriter::kTempMarker, "") ||
               left_by_dead_build(entry, HlodWriter::kTempMarker, HlodWriter::kSpoolSuffix);
    });
    return removed;
}

void check_settings(const BuildSettings& s) {
    auto fail = [](const std::string& what) { throw InputError("build settings: " + what); };
    if (s.levels < -1 || s.levels > kMaxLevels) fail("--levels must be auto or 0.." + std::to_string(kMaxLevels));
    if (s.block < 4 || s.block % 4 != 0 || s.block > 64) fail("--block must be a multiple of 4 from 4 to 64");
    if (!(s.ratio > 0 && s.ratio < 1)) fail("--ratio must lie strictly between 0 and 1");
    if (!(s.sigma0 >= 0.1f && s.sigma0 <= kMaxSigma0)) fail("--sigma0 must lie in [0.1, 0.45]");
    if (!(s.error == -1 || s.error > 0)) fail("--error must be positive");
    if (s.threads < 0) fail("--threads must be 0 (all cores) or more");
    if (s.leaf_triangles < 16) fail("leaf size must be at least 16 triangles");
    if (s.memory != 0 && s.memory < kLeastMemory) fail("--memory must be at least 16M: the build's buffers need that much");
}

BuildReport build_hlod(Mesh&& mesh, const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress) {
    if (mesh.vertex_count() >= 0xFFFFFFFFu) throw InputError(source_name + ": more than 2^32 vertices");
    const ModelAttributes model{{mesh.has_normals(), mesh.has_colors(), mesh.has_uvs()}, mesh.texture};
    std::vector<std::unique_ptr<TriangleSource>> sources;
    sources.push_back(mesh_source(std::move(mesh), source_name));
    return build_hlod(sources, model, output, settings, source_name, progress);
}

BuildReport build_hlod(const std::vector<std::unique_ptr<TriangleSource>>& sources, const ModelAttributes& model,
                       const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress) {
    check_settings(settings);
    BuildReport report;
    build::InputScan scan;
    {
        StageTimer timer(report.read_seconds);
        scan = build::scan_inputs(sources, progress);
    }
    if (scan.triangles == 0 && scan.degenerate > 0 && scan.corner_low == scan.corner_high)
        throw InputError(source_name + ": every vertex lies at one point");
    if (scan.triangles == 0)
        throw InputError(source_name + (scan.degenerate > 0 ? ": every triangle has two corners at one point"
                                                            : ": the mesh has no triangles"));
    Frame f = build::make_frame(scan, source_name);
    f.block = uint32_t(settings.block);

    // σ0 and L together (DESIGN.md §2): pick L, then the σ0 the data needs; never break constraint 1.
    const bool automatic = settings.levels < 0;
    uint32_t L = automatic ? build::choose_levels(scan, f, settings.leaf_triangles, kMaxLevels) : uint32_t(settings.levels);
    // At L = 0 every vertex lies in the root cell and nothing morphs: no edge bound applies there,
    // so capping L always ends in a model.
    const double edge = scan.longest_edge;
    auto needed_sigma0 = [&](uint32_t levels) { return levels == 0 ? 0.0 : edge / f.cube_size(levels); };
    while (needed_sigma0(L) > kMaxSigma0) {
        if (!automatic || L == 0)
            throw InputError(source_name + ": edges up to " + std::to_string(edge) + " long need σ0 = " +
                             std::to_string(needed_sigma0(L)) + " > " + std::to_string(kMaxSigma0) +
                             " at " + std::to_string(L) + " levels; use fewer --levels");
        --L;
        report.notes.push_back("levels capped at " + std::to_string(L) + ": the input has edges of " +
                               std::to_string(edge) + " (max norm)");
    }
    f.max_level = L;
    f.sigma0 = std::max(settings.sigma0, float(needed_sigma0(L)));
    if (f.sigma0 > settings.sigma0)
        report.notes.push_back("σ0 raised to " + std::to_string(f.sigma0) + " by the input's longest edge");

    HlodHeader header;
    header.flags = (model.kept.colors ? kHasColors : 0u) | (model.kept.uvs ? kHasUvs : 0u);
    const std::array<double, 3> origin = sources.front()->origin();
    for (int a = 0; a < 3; ++a) header.origin[a] = origin[size_t(a)] + f.origin[a];  // in double: survey coordinates
    header.root_size = f.root_size;
    header.max_level = L;
    header.block_size = f.block;
    header.sigma0 = f.sigma0;
    header.ratio = settings.ratio;
    header.error_limit = settings.error;
    header.input_triangles = scan.triangles;
    header.source = source_name;
    header.texture = model.texture;

    HlodWriter writer(output);
    const WorkFolder work(output, settings.temp_dir);
    const unsigned threads = resolve_thread_count(settings.threads);
    const uint64_t memory = settings.memory ? settings.memory : default_memory_limit();
    // What a spill may hold back before writing: a quarter of the limit, but beyond 256 MiB larger
    // buffers only make longer chunks on disk (all of it is written out anyway).
    const uint64_t spill_buffer = std::min(memory / 4, kMostSpillBuffer);
    build::DiskUsage disk;
    auto level_file = [&](uint32_t l) { return work / ("level-" + std::to_string(l) + ".cubes"); };
    auto listings = [&](uint32_t l) {
        return std::make_unique<build::RunSpill>(work / ("level-" + std::to_string(l) + ".border"), disk, spill_buffer);
    };
    auto level = std::make_unique<build::CubeStore>(level_file(L), disk);
    auto listed = listings(L);
    {
        StageTimer timer(report.partition_seconds);
        build::RunSpill spill(work / "triangles.spill", disk, spill_buffer);
        const build::CornerLayout layout{model.kept};
        uint64_t done = 0;
        for (const auto& source : sources)
            source->for_each(
                [&](const TriangleBatch& batch) {
                    build::spill_triangles(batch, f, layout, spill);
                    done += batch.triangle_count();
                    progress("partition", double(done), double(std::max(done, scan.triangles)), "tri");
                },
                progress);
        spill.finish();
        build::leaf_cubes(spill, layout, f, threads, *level, *listed, progress);
        listed->finish();
        report.spill_memory_bytes = spill.memory_bytes();
    }
    for (const auto& source : sources) report.source_memory_bytes = std::max(report.source_memory_bytes, source->memory_bytes());
    progress.check();

    float error_q = 0;
    for (uint32_t l = L; l > 0; --l) {
        report.levels.push_back(LevelStats{l});
        StageTimer timer(report.simplify_seconds);
        LevelWriter out(writer, report.levels.back(), f);
        auto next = std::make_unique<build::CubeStore>(level_file(l - 1), disk);
        auto next_listed = listings(l - 1);
        simplify_level(*level, *listed, l, f, settings, header.flags, out, *next, *next_listed, progress);
        report.border_bytes = std::max(report.border_bytes, next_listed->memory_bytes());
        error_q = std::max(error_q, out.relative_error());
        level = std::move(next);
        listed = std::move(next_listed);
    }
    progress.check();
    report.levels.push_back(LevelStats{0});
    {
        StageTimer timer(report.write_seconds);
        LevelWriter out(writer, report.levels.back(), f);
        const build::CubeRecord root = level->get(level->keys().at(0));
        out.add(build::encode_root(root, build::whole_border_table(*listed), f, header.flags));
        error_q = std::max(error_q, out.relative_error());
    }
    report.temp_bytes = disk.peak();

    header.error_q = error_q;
    header.input_vertices = report.levels.front().vertices;
    {
        StageTimer timer(report.write_seconds);
        writer.finish(header);
    }
    report.input_triangles = scan.triangles;
    report.max_level = L;
    report.sigma0 = f.sigma0;
    report.error_q = error_q;
    std::error_code ec;
    report.output_bytes = std::filesystem::file_size(output, ec);
    return report;
}

}  // namespace strata
