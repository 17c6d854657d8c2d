#include "preprocess/hlod_builder.h"

#include "preprocess/atomic_file.h"
#include "preprocess/build_jobs.h"
#include "preprocess/build_plan.h"
#include "preprocess/byte_size.h"
#include "preprocess/hlod_format.h"
#include "preprocess/input_scan.h"
#include "preprocess/job_files.h"
#include "preprocess/parallel.h"
#include "preprocess/run_spill.h"
#include "preprocess/triangle_spill.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>

namespace strata {
namespace {

using build::BuildPlan;
using build::CubeKey;
using build::Frame;
using build::WorkPaths;

// The 16-bit lattice holds a cell plus an overhang below half a cell on each side.
constexpr float kMaxSigma0 = 0.45f;
constexpr int kMaxLevels = 15;  // keeps the lattice integer q = 2^15·cell + … within 31 bits
constexpr uint64_t kLeastMemory = uint64_t(16) << 20;
constexpr uint64_t kMostSpillBuffer = uint64_t(256) << 20;
// A build of OUT keeps its work in OUT<kWorkSuffix>, in temp_folder() (remove_build_leftovers looks there).
constexpr std::string_view kWorkSuffix = ".build";

// Adds the wall time of its scope to a counter.
class StageTimer {
public:
    explicit StageTimer(double& total) : total_(total), start_(std::chrono::steady_clock::now()) {}
    ~StageTimer() { total_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

private:
    double& total_;
    std::chrono::steady_clock::time_point start_;
};

bool file_exists(const std::filesystem::path& path) {
    std::error_code ec;
    return std::filesystem::exists(path, ec);
}

std::filesystem::path folder_or_here(const std::filesystem::path& folder) {
    return folder.empty() ? std::filesystem::path(".") : folder;
}

WorkPaths work_paths(const std::filesystem::path& output, const std::filesystem::path& temp_dir) {
    return WorkPaths{temp_folder(output, temp_dir) / (output.filename().string() + std::string(kWorkSuffix))};
}

// One build at a time in a work folder: an exclusive flock on its "lock" file, held while the build
// runs and let go by the kernel when the process ends, however it ends.
class WorkLock {
public:
    // Creates the folder. Throws InputError when another build holds it, std::runtime_error when the
    // folder cannot be made.
    explicit WorkLock(const std::filesystem::path& dir) {
        std::error_code ec;
        std::filesystem::create_directories(dir, ec);
        if (ec) throw std::runtime_error(dir.string() + ": cannot create the build's work folder (" + ec.message() + ")");
        fd_ = ::open((dir / "lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd_ < 0) throw std::runtime_error(dir.string() + ": cannot create the build's lock (" + std::strerror(errno) + ")");
        if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
            ::close(fd_);
            throw InputError(dir.string() + ": another build of this output is running there");
        }
    }
    ~WorkLock() { ::close(fd_); }
    WorkLock(const WorkLock&) = delete;
    WorkLock& operator=(const WorkLock&) = delete;

    // Whether a running build holds the folder's lock.
    static bool held(const std::filesystem::path& dir) {
        const int fd = ::open((dir / "lock").c_str(), O_RDWR | O_CLOEXEC);
        if (fd < 0) return false;
        const bool locked = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
        ::close(fd);
        return locked;
    }

private:
    int fd_ = -1;
};

// Everything in the folder but its lock.
void empty_folder(const std::filesystem::path& dir) {
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec))
        if (e.path().filename() != "lock") std::filesystem::remove_all(e.path(), ec);
}

uint64_t folder_bytes(const std::filesystem::path& dir) {
    uint64_t bytes = 0;
    std::error_code ec;
    for (const auto& e : std::filesystem::recursive_directory_iterator(dir, ec)) {
        struct stat st {};
        if (::stat(e.path().c_str(), &st) == 0 && S_ISREG(st.st_mode)) bytes += uint64_t(st.st_blocks) * 512;
    }
    return bytes;
}

// Whether `entry` is "<name><marker><pid><suffix>" for a process that is gone.
bool left_by_dead_process(const std::string& entry, const std::string& name, std::string_view marker, std::string_view suffix) {
    const std::string prefix = name + std::string(marker);
    if (entry.size() <= prefix.size() + suffix.size() || entry.compare(0, prefix.size(), prefix) != 0 ||
        entry.compare(entry.size() - suffix.size(), suffix.size(), suffix) != 0)
        return false;
    const std::string pid = entry.substr(prefix.size(), entry.size() - prefix.size() - suffix.size());
    if (pid.empty() || pid.size() > 9 || !std::all_of(pid.begin(), pid.end(), ::isdigit)) return false;
    return ::kill(pid_t(std::stol(pid)), 0) != 0 && errno == ESRCH;
}

// The writer's temporary files of `output` that killed processes left; removed, their paths appended.
void remove_dead_writers(const std::filesystem::path& output, std::vector<std::filesystem::path>& removed) {
    const std::string name = output.filename().string();
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(folder_or_here(output.parent_path()), ec)) {
        const std::string entry = e.path().filename().string();
        if (left_by_dead_process(entry, name, HlodWriter::kTempMarker, "") ||
            left_by_dead_process(entry, name, HlodWriter::kTempMarker, HlodWriter::kSpoolSuffix)) {
            std::filesystem::remove(e.path(), ec);
            removed.push_back(e.path());
        }
    }
}

// ---- the plan: two passes over the input ----------------------------------------------------------

// Pass 1 and the choices made from it: the frame, L and σ0 (DESIGN.md §2), and the header.
void choose_frame(const build::InputScan& scan, const BuildInput& input, const BuildSettings& settings,
                  const std::string& source_name, BuildPlan& plan) {
    if (scan.triangles == 0 && scan.degenerate > 0 && scan.corner_low == scan.corner_high)
        throw InputError(source_name + ": every vertex lies at one point");
    if (scan.triangles == 0)
        throw InputError(source_name + (scan.degenerate > 0 ? ": every triangle has two corners at one point"
                                                            : ": the mesh has no triangles"));
    Frame f = build::make_frame(scan, source_name);
    f.block = uint32_t(settings.block);

    // σ0 and L together: pick L, then the σ0 the data needs; never break constraint 1.
    const bool automatic = settings.levels < 0;
    uint32_t L = automatic ? build::choose_levels(scan, f, settings.leaf_triangles, kMaxLevels) : uint32_t(settings.levels);
    // A locked boundary's vertices snap to level 0's lattice, each coordinate by up to h_0/2 (FORMAT.md
    // §6): the mesh the levels hold then has edges up to h_0 longer, and vertices up to h_0/2 farther out.
    const double snap = settings.lock_boundary ? f.root_size / double(1 << kLatticeBits) : 0.0;
    const double edge = scan.longest_edge + snap;
    // At L = 0 every vertex lies in the root cell and nothing morphs: no edge bound applies there,
    // so capping L always ends in a model.
    auto needed_sigma0 = [&](uint32_t levels) { return levels == 0 ? 0.0 : edge / f.cube_size(levels); };
    while (needed_sigma0(L) > kMaxSigma0) {
        if (!automatic || L == 0)
            throw InputError(source_name + ": edges up to " + std::to_string(edge) + " long need σ0 = " +
                             std::to_string(needed_sigma0(L)) + " > " + std::to_string(kMaxSigma0) +
                             " at " + std::to_string(L) + " levels; use fewer --levels");
        --L;
        plan.notes.push_back("levels capped at " + std::to_string(L) + ": the input has edges of " +
                             std::to_string(edge) + " (max norm)");
    }
    f.max_level = L;
    f.sigma0 = std::max(settings.sigma0, float(needed_sigma0(L)));
    if (f.sigma0 > settings.sigma0)
        plan.notes.push_back("σ0 raised to " + std::to_string(f.sigma0) + " by the input's longest edge" +
                             (snap > 0 ? " and the boundary's snap to level 0's lattice" : ""));
    plan.frame = f;

    HlodHeader& header = plan.header;
    header.flags = (input.model.kept.colors ? kHasColors : 0u) | (input.model.kept.uvs ? kHasUvs : 0u) | kErrorsAreBounds |
                   (settings.lock_boundary ? kLockedBoundary : 0u);
    const std::array<double, 3> origin = input.sources.front()->origin();
    for (int a = 0; a < 3; ++a) header.origin[a] = origin[size_t(a)] + f.origin[a];  // in double: survey coordinates
    header.has_bounds = true;
    for (int a = 0; a < 3; ++a) {
        header.bounds_lo[a] = origin[size_t(a)] + scan.low[size_t(a)];
        header.bounds_hi[a] = origin[size_t(a)] + scan.high[size_t(a)];
    }
    header.root_size = f.root_size;
    header.max_level = L;
    header.block_size = f.block;
    header.sigma0 = f.sigma0;
    header.ratio = settings.ratio;
    header.error_limit = settings.error;
    header.input_triangles = scan.triangles;
    header.source = source_name;
    header.texture = input.model.texture;
    plan.kept = input.model.kept;
}

// Pass 2: every proper triangle to its level-L block's run, in a spill the plan's jobs read.
void spill_input(const BuildInput& input, uint64_t triangles, const BuildSettings& settings, const WorkPaths& work,
                 build::DiskUsage& disk, const Progress& progress, BuildPlan& plan) {
    const uint64_t memory = settings.memory ? settings.memory : default_memory_limit();
    // What the spill may hold back before writing: a quarter of the limit, but beyond 256 MiB larger
    // buffers only make longer chunks on disk (all of it is written out anyway).
    build::RunSpill spill(work.spill(), disk, std::min(memory / 4, kMostSpillBuffer), build::ScratchFile::Lifetime::kept);
    const build::CornerLayout layout{plan.kept};
    uint64_t done = 0;
    for (const auto& source : input.sources)
        source->for_each(
            [&](const TriangleBatch& batch) {
                build::spill_triangles(batch, plan.frame, layout, spill);
                done += batch.triangle_count();
                progress("partition", double(done), double(std::max(done, triangles)), "tri");
            },
            progress);
    spill.finish();
    plan.spill_memory_bytes = spill.memory_bytes();
    for (const auto& source : input.sources) plan.source_memory_bytes = std::max(plan.source_memory_bytes, source->memory_bytes());
    ByteWriter index;
    spill.save_index(index);
    plan.spill_index = std::move(index.bytes);
    build::plan_stages(plan, spill.keys());
}

BuildPlan make_plan(const OpenInput& open, const std::vector<std::filesystem::path>& files, const WorkPaths& work,
                    const BuildSettings& settings, const std::string& source_name, build::DiskUsage& disk,
                    const Progress& progress) {
    BuildPlan plan;
    plan.settings = settings;
    plan.inputs = build::record_inputs(files);
    const BuildInput input = open();
    build::InputScan scan;
    {
        StageTimer timer(plan.read_seconds);
        scan = build::scan_inputs(input.sources, progress);
    }
    choose_frame(scan, input, settings, source_name, plan);
    {
        StageTimer timer(plan.spill_seconds);
        spill_input(input, scan.triangles, settings, work, disk, progress, plan);
    }
    build::save_plan(plan, work.plan());
    const std::string jobs = build::describe_jobs(plan);
    AtomicOutputFile list(work.job_list());
    list.write(jobs.data(), jobs.size());
    list.commit();
    return plan;
}

// A resumed build must make the model the killed one would have: same settings, same input.
void check_resumable(const BuildPlan& plan, const BuildSettings& settings, const std::vector<std::filesystem::path>& files,
                     const std::filesystem::path& output) {
    const std::string hint = "; build without --resume after strata build --clean " + output.string();
    const std::string setting = build::settings_differ(plan.settings, settings);
    if (!setting.empty()) throw InputError("cannot resume " + output.string() + ": it was begun with " + setting + hint);
    const std::vector<build::InputRecord> now = build::record_inputs(files);
    for (size_t i = 0; i < std::max(now.size(), plan.inputs.size()); ++i) {
        if (i < now.size() && i < plan.inputs.size() && now[i] == plan.inputs[i]) continue;
        const std::string what = i >= plan.inputs.size() ? now[i].path + " was not among its inputs"
                                 : i >= now.size()       ? plan.inputs[i].path + " is missing from the inputs"
                                 : now[i].path != plan.inputs[i].path
                                     ? "its input " + std::to_string(i + 1) + " was " + plan.inputs[i].path + ", not " + now[i].path
                                     : now[i].path + " changed since it began";
        throw InputError("cannot resume " + output.string() + ": " + what + hint);
    }
}

// ---- running the jobs -----------------------------------------------------------------------------

uint64_t finished_jobs(const BuildPlan& plan, const WorkPaths& work) {
    uint64_t finished = 0;
    for (size_t s = 0; s < plan.stages.size(); ++s)
        finished += plan.stages[s].blocks.size() - build::unfinished_jobs(work, s, plan.stages[s].blocks).size();
    return finished;
}

// Every unfinished job, stage after stage, on this machine.
void run_every_job(const BuildPlan& plan, const WorkPaths& work, unsigned threads, build::DiskUsage& disk,
                   const Progress& progress, BuildReport& report) {
    for (size_t s = 0; s < plan.stages.size(); ++s) {
        StageTimer timer(s == 0 ? report.partition_seconds : report.simplify_seconds);
        if (build::stage_finished(plan, work, s, disk)) continue;
        const build::JobStats stats = build::run_jobs(plan, work, s, plan.stages[s].blocks, threads, true, disk, progress);
        report.border_bytes = std::max(report.border_bytes, stats.border_bytes);
        if (!build::stage_finished(plan, work, s, disk)) throw std::logic_error("a stage's jobs ran but it has not finished");
    }
}

BuildReport assembled_report(const BuildPlan& plan, const build::Assembly& assembly) {
    BuildReport report;
    report.max_level = plan.frame.max_level;
    report.sigma0 = plan.frame.sigma0;
    report.error_q = assembly.error_q;
    report.levels = assembly.levels;
    report.notes = plan.notes;
    report.input_triangles = plan.header.input_triangles;
    report.output_bytes = assembly.output_bytes;
    report.boundary_points = assembly.boundary_points;
    report.jobs = plan.job_count();
    return report;
}

// The first stage whose jobs have not all finished, as an error.
[[noreturn]] void unfinished_stage(const BuildPlan& plan, const WorkPaths& work, size_t stage, const std::string& what) {
    const build::Stage& s = plan.stages[stage];
    uint64_t left = 0, first = 0;
    for (size_t b = s.blocks.size(); b-- > 0;)
        if (!build::job_finished(work, stage, s.blocks[b])) ++left, first = s.first_job + b;
    throw InputError(what + ": stage " + std::to_string(stage) + " (jobs " + std::to_string(s.first_job) + "-" +
                     std::to_string(s.first_job + s.blocks.size() - 1) + ") has " + std::to_string(left) +
                     " unfinished job" + (left == 1 ? "" : "s") + ", the first job " + std::to_string(first));
}

// Every unfinished job of the plan, then the assembly; the report of the whole build.
BuildReport build_from_plan(const BuildPlan& plan, const WorkPaths& work, const std::filesystem::path& output,
                            unsigned threads, build::DiskUsage& disk, const Progress& progress) {
    BuildReport jobs;  // what running the jobs measured
    jobs.jobs_resumed = finished_jobs(plan, work);
    jobs.partition_seconds = plan.spill_seconds;
    run_every_job(plan, work, threads, disk, progress, jobs);
    progress.check();
    double write_seconds = 0;
    build::Assembly assembly;
    {
        StageTimer timer(write_seconds);
        assembly = build::assemble(plan, work, output, progress);
    }
    BuildReport report = assembled_report(plan, assembly);
    report.read_seconds = plan.read_seconds, report.partition_seconds = jobs.partition_seconds;
    report.simplify_seconds = jobs.simplify_seconds, report.write_seconds = write_seconds;
    report.border_bytes = jobs.border_bytes;
    report.spill_memory_bytes = plan.spill_memory_bytes, report.source_memory_bytes = plan.source_memory_bytes;
    report.temp_bytes = disk.peak();
    report.jobs_resumed = jobs.jobs_resumed;
    return report;
}

void remove_work_folder(const std::filesystem::path& dir) {
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
}

}  // namespace

void check_output_folder(const std::filesystem::path& output) {
    const std::filesystem::path folder = folder_or_here(output.parent_path());
    struct stat st {};
    const int error = ::stat(folder.c_str(), &st) != 0 ? errno : !S_ISDIR(st.st_mode) ? ENOTDIR
                                                          : ::access(folder.c_str(), W_OK) != 0 ? errno : 0;
    if (error) throw std::runtime_error(output.string() + ": cannot create the output file (" + std::strerror(error) + ")");
}

std::filesystem::path temp_folder(const std::filesystem::path& output, const std::filesystem::path& temp_dir) {
    return folder_or_here(temp_dir.empty() ? output.parent_path() : temp_dir);
}

uint64_t leftover_bytes(const std::filesystem::path& output, const std::filesystem::path& temp_dir) {
    return folder_bytes(work_paths(output, temp_dir).dir);
}

std::vector<std::filesystem::path> remove_build_leftovers(const std::filesystem::path& output,
                                                          const std::filesystem::path& temp_dir) {
    std::vector<std::filesystem::path> removed;
    const WorkPaths work = work_paths(output, temp_dir);
    if (file_exists(work.dir) && !WorkLock::held(work.dir)) {
        remove_work_folder(work.dir);
        removed.push_back(work.dir);
    }
    remove_dead_writers(output, removed);
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
    BuildInput input;
    input.model = ModelAttributes{{mesh.has_normals(), mesh.has_colors(), mesh.has_uvs()}, mesh.texture};
    input.sources.push_back(mesh_source(std::move(mesh), source_name));
    return build_hlod(std::move(input), output, settings, source_name, progress);
}

BuildReport build_hlod(BuildInput input, const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress) {
    auto open = [&input] { return std::move(input); };
    return build_hlod(open, {}, output, settings, source_name, progress);
}

BuildReport build_hlod(const OpenInput& open, const std::vector<std::filesystem::path>& files,
                       const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress) {
    check_settings(settings);
    check_output_folder(output);
    const WorkPaths work = work_paths(output, settings.temp_dir);
    if (settings.resume && !file_exists(work.dir) && file_exists(output)) {
        BuildReport report;
        report.already_complete = true;
        std::error_code ec;
        report.output_bytes = std::filesystem::file_size(output, ec);
        return report;
    }
    const WorkLock lock(work.dir);
    const bool planned = file_exists(work.plan());
    if (planned && !settings.resume)
        throw InputError(work.dir.string() + ": a build of " + output.string() +
                         " was killed or failed here; add --resume to go on from its finished blocks, or remove it "
                         "with strata build --clean " + output.string());
    std::vector<std::filesystem::path> ignored;
    remove_dead_writers(output, ignored);
    build::DiskUsage disk;
    disk.add(folder_bytes(work.dir));
    bool plan_on_disk = planned;
    try {
        BuildPlan plan;
        if (planned) {
            plan = build::load_plan(work.plan());
            check_resumable(plan, settings, files, output);
        } else {
            empty_folder(work.dir);
            plan = make_plan(open, files, work, settings, source_name, disk, progress);
            plan_on_disk = true;
        }
        BuildReport report = build_from_plan(plan, work, output, resolve_thread_count(settings.threads), disk, progress);
        report.resumed = planned;
        remove_work_folder(work.dir);
        return report;
    } catch (const Cancelled&) {
        remove_work_folder(work.dir);
        throw;
    } catch (const InputError&) {
        if (!plan_on_disk) remove_work_folder(work.dir);  // bad input: nothing to go on from
        throw;
    } catch (const build::DamagedWork&) {
        throw;  // nothing to go on from: the message says to start over
    } catch (const std::runtime_error& e) {
        if (!plan_on_disk) {
            remove_work_folder(work.dir);
            throw;
        }
        throw std::runtime_error(std::string(e.what()) + " (the finished blocks are kept in " + work.dir.string() +
                                 ": run the same command with --resume to go on)");
    }
}

std::string plan_build(const OpenInput& open, const std::vector<std::filesystem::path>& files,
                       const std::filesystem::path& dir, const BuildSettings& settings, const std::string& source_name,
                       const Progress& progress) {
    check_settings(settings);
    std::error_code ec;
    if (file_exists(dir) && !std::filesystem::is_empty(dir, ec))
        throw InputError(dir.string() + ": already holds files; --plan needs a new or empty folder");
    const WorkPaths work{dir};
    const WorkLock lock(dir);
    build::DiskUsage disk;
    try {
        return build::describe_jobs(make_plan(open, files, work, settings, source_name, disk, progress));
    } catch (...) {
        remove_work_folder(dir);  // it held nothing before
        throw;
    }
}

namespace {

BuildPlan load_job_plan(const WorkPaths& work) {
    if (!file_exists(work.plan()))
        throw InputError(work.dir.string() + ": holds no build plan (make one with strata build IN... --plan " +
                         work.dir.string() + ")");
    return build::load_plan(work.plan());
}

}  // namespace

JobRunReport run_build_jobs(const std::filesystem::path& dir, uint64_t first, uint64_t last, int threads,
                            const Progress& progress) {
    const WorkPaths work{dir};
    const BuildPlan plan = load_job_plan(work);
    if (first > last || last >= plan.job_count())
        throw InputError(dir.string() + ": no jobs " + std::to_string(first) + "-" + std::to_string(last) +
                         " in its plan, which has jobs 0-" + std::to_string(plan.job_count() - 1));
    build::DiskUsage disk;
    JobRunReport report;
    for (size_t s = plan.stage_of(first); s <= plan.stage_of(last); ++s) {
        const build::Stage& stage = plan.stages[s];
        if (s > 0 && !build::stage_finished(plan, work, s - 1, disk))
            unfinished_stage(plan, work, s - 1, "jobs of stage " + std::to_string(s) + " need the stage before finished");
        const uint64_t from = std::max(first, stage.first_job) - stage.first_job;
        const uint64_t to = std::min(last, stage.first_job + stage.blocks.size() - 1) - stage.first_job;
        const std::vector<build::CubeKey> blocks(stage.blocks.begin() + int64_t(from), stage.blocks.begin() + int64_t(to) + 1);
        const uint64_t ran = build::run_jobs(plan, work, s, blocks, resolve_thread_count(threads), false, disk, progress).run;
        report.run += ran;
        report.already_finished += blocks.size() - ran;
        build::stage_finished(plan, work, s, disk);  // marks it when these were its last jobs
    }
    return report;
}

BuildReport assemble_build(const std::filesystem::path& dir, const std::filesystem::path& output, const Progress& progress) {
    const WorkPaths work{dir};
    const BuildPlan plan = load_job_plan(work);
    check_output_folder(output);
    build::DiskUsage disk;
    for (size_t s = 0; s < plan.stages.size(); ++s)
        if (!build::stage_finished(plan, work, s, disk)) unfinished_stage(plan, work, s, "cannot assemble " + output.string());
    std::vector<std::filesystem::path> ignored;
    remove_dead_writers(output, ignored);
    BuildReport report;
    {
        StageTimer timer(report.write_seconds);
        report = assembled_report(plan, build::assemble(plan, work, output, progress));
    }
    remove_work_folder(dir);
    return report;
}

}  // namespace strata
