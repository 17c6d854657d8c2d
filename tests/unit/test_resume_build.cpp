// --resume (issue 14): a build killed outright (SIGKILL, in a forked child, from its progress callback
// at a chosen point of a chosen stage, while other worker threads may be writing) and resumed makes
// the bytes of an uninterrupted build; a resumed build with a setting or an input that changes the
// output is refused by name; and the build split into plan, job ranges and assembly, as a cluster
// runs it, makes the same bytes too.
#include "preprocess/build_inputs.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/mesh_io.h"
#include "tests/support/test_meshes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <iterator>
#include <sstream>
#include <thread>

namespace strata {
namespace {

using ::testing::HasSubstr;

BuildSettings small_settings() {
    BuildSettings s;
    s.levels = 4;  // five stages of jobs, dozens of blocks in the first ones
    s.threads = 2;
    s.memory = uint64_t(16) << 20;
    return s;
}

class ResumeBuild : public ::testing::Test {
protected:
    void SetUp() override {
        Mesh sphere = test::icosphere(6);  // 81 920 triangles
        for (size_t v = 0; v < sphere.vertex_count(); ++v)
            sphere.colors.insert(sphere.colors.end(), {uint8_t(v), uint8_t(v >> 8), 9, 255});
        write_ply(input(), sphere);
        build(reference(), small_settings());
    }

    std::filesystem::path input() const { return dir_ / "sphere.ply"; }
    std::filesystem::path reference() const { return dir_ / "reference.hlod"; }
    std::filesystem::path output() const { return dir_ / "out.hlod"; }
    std::filesystem::path work() const { return dir_ / "out.hlod.build"; }

    BuildReport build(const std::filesystem::path& out, const BuildSettings& s, const Progress& progress = {}) {
        std::vector<std::string> warnings;
        return build_hlod(input_from_files({input()}, s.memory, progress, warnings), {input()}, out, s, "sphere.ply",
                          progress);
    }

    // Builds output() in a child process that kills itself with SIGKILL at the `report`-th progress
    // report of `stage` (kStageDone: at the report that says the stage's work is all done). Returns
    // whether it was killed (false: it never got there).
    static constexpr int kStageDone = -1;
    bool build_killed_at(const std::string& stage, int report, const BuildSettings& s) {
        const pid_t child = ::fork();
        if (child == 0) {
            int seen = 0;
            Progress progress;
            progress.report = [&](std::string_view now, double done, double total, std::string_view) {
                if (now == stage && (report == kStageDone ? done == total : ++seen >= report)) ::raise(SIGKILL);
            };
            try {
                build(output(), s, progress);
            } catch (...) {
            }
            ::_exit(0);
        }
        int status = 0;
        ::waitpid(child, &status, 0);
        return WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
    }

    test::TempDir dir_;
};

// Every stage: the two passes over the input (scan, partition), each stage of jobs, between two
// stages, and the assembly.
TEST_F(ResumeBuild, KilledAnywhereItResumesToTheBytesOfAnUninterruptedBuild) {
    const std::vector<uint8_t> want = test::file_bytes(reference());
    ASSERT_FALSE(want.empty());
    const std::vector<std::pair<std::string, int>> kills = {
        {"scan", 1},          {"partition", 2},          {"level cubes", 3},      {"level cubes", kStageDone},
        {"simplify level 4", 2}, {"simplify level 3", 1}, {"simplify level 1", 1}, {"write", 5}};
    for (const auto& [stage, report] : kills) {
        SCOPED_TRACE(stage + ", report " + std::to_string(report));
        BuildSettings s = small_settings();
        ASSERT_TRUE(build_killed_at(stage, report, s)) << "the build never reached " << stage;
        EXPECT_FALSE(std::filesystem::exists(output())) << "a killed build left an output";
        ASSERT_TRUE(std::filesystem::exists(work())) << "a killed build removed its work folder";
        const bool planned = stage != "scan" && stage != "partition";
        if (planned) {  // its finished jobs are refused without --resume, not thrown away
            try {
                build(output(), s);
                ADD_FAILURE() << "built over a killed build's work folder without --resume";
            } catch (const InputError& e) {
                EXPECT_THAT(e.what(), HasSubstr("add --resume"));
            }
        }
        s.resume = true;
        s.threads = 1, s.memory = uint64_t(64) << 20;  // neither changes the output
        const BuildReport resumed = build(output(), s);
        EXPECT_EQ(test::file_bytes(output()), want);
        EXPECT_FALSE(std::filesystem::exists(work())) << "the resumed build left its work folder";
        EXPECT_EQ(resumed.resumed, planned) << "killed before its plan was whole, a build starts over";
        if (planned) {
            EXPECT_GT(resumed.jobs_resumed, 0u);
        }
        if (stage == "write") {
            EXPECT_EQ(resumed.jobs_resumed, resumed.jobs) << "every job had finished";
        }
        std::filesystem::remove(output());
    }
}

TEST_F(ResumeBuild, ASettingThatChangesTheOutputIsRefusedByName) {
    ASSERT_TRUE(build_killed_at("simplify level 4", 1, small_settings()));
    auto refused = [&](BuildSettings s, const std::string& name) {
        s.resume = true;
        try {
            build(output(), s);
            ADD_FAILURE() << "resumed with another " << name;
        } catch (const InputError& e) {
            EXPECT_THAT(e.what(), HasSubstr("cannot resume " + output().string() + ": it was begun with " + name)) << e.what();
        }
        EXPECT_FALSE(std::filesystem::exists(output()));
        EXPECT_TRUE(std::filesystem::exists(work() / "plan")) << "a refused resume must keep what it refused";
    };
    BuildSettings s = small_settings();
    s.ratio = 0.3f;
    refused(s, "--ratio 0.25 (now 0.3)");
    s = small_settings(), s.levels = 5;
    refused(s, "--levels 4 (now 5)");
    s = small_settings(), s.block = 8;
    refused(s, "--block 4 (now 8)");
    s = small_settings(), s.sigma0 = 0.3f;
    refused(s, "--sigma0");
    s = small_settings(), s.error = 0.01f;
    refused(s, "--error -1 (now 0.01)");
    s = small_settings(), s.lock_boundary = true;
    refused(s, "no --lock-boundary (now with it)");

    // The input changed since: refused, naming it.
    std::filesystem::last_write_time(input(), std::filesystem::last_write_time(input()) + std::chrono::seconds(5));
    s = small_settings(), s.resume = true;
    try {
        build(output(), s);
        ADD_FAILURE() << "resumed from a changed input";
    } catch (const InputError& e) {
        EXPECT_THAT(e.what(), HasSubstr(input().string() + " changed since it began"));
    }
    remove_build_leftovers(output(), {});
    EXPECT_FALSE(std::filesystem::exists(work()));
}

// A locked boundary is found by the first simplifying stage from lists the first stage's jobs left
// (open_boundary.h): killed before, between or after them, a build resumes to the same bytes. The sphere
// opened by a cap cut off at z > 0.6, whose rim crosses many of level 4's blocks.
TEST_F(ResumeBuild, ALockedBoundaryResumesToTheBytesOfAnUninterruptedBuild) {
    Mesh sphere = test::icosphere(6);
    std::vector<uint32_t> kept;
    for (size_t t = 0; t < sphere.indices.size(); t += 3) {
        float z = 0;
        for (int c = 0; c < 3; ++c) z += sphere.positions[3 * size_t(sphere.indices[t + c]) + 2] / 3;
        if (z <= 0.6f) kept.insert(kept.end(), &sphere.indices[t], &sphere.indices[t] + 3);
    }
    sphere.indices = kept;
    write_ply(input(), sphere);
    BuildSettings s = small_settings();
    s.lock_boundary = true;
    const BuildReport reference_report = build(reference(), s);
    EXPECT_GT(reference_report.boundary_points, 100u);
    EXPECT_TRUE(verify_hlod(HlodFile(reference())).boundary_locked);
    const std::vector<uint8_t> want = test::file_bytes(reference());
    for (const auto& [stage, report] : std::vector<std::pair<std::string, int>>{
             {"level cubes", 3}, {"level cubes", kStageDone}, {"simplify level 4", 2}, {"simplify level 3", 1}}) {
        SCOPED_TRACE(stage + ", report " + std::to_string(report));
        s.resume = false;
        ASSERT_TRUE(build_killed_at(stage, report, s)) << "the build never reached " << stage;
        s.resume = true;
        const BuildReport resumed = build(output(), s);
        EXPECT_TRUE(resumed.resumed);
        EXPECT_EQ(resumed.boundary_points, reference_report.boundary_points);
        EXPECT_EQ(test::file_bytes(output()), want);
        std::filesystem::remove(output());
    }
}

// Damage in the work folder is an error naming the file and saying to start over, not to resume.
TEST_F(ResumeBuild, DamagedWorkIsAnErrorSayingToStartOver) {
    ASSERT_TRUE(build_killed_at("simplify level 3", 1, small_settings()));
    BuildSettings s = small_settings();
    s.resume = true;
    auto fails_naming = [&](const std::filesystem::path& file) {
        try {
            build(output(), s);
            ADD_FAILURE() << "resumed from damaged " << file;
        } catch (const std::runtime_error& e) {
            EXPECT_THAT(e.what(), HasSubstr(file.string()));
            EXPECT_THAT(e.what(), HasSubstr("strata build --clean) and build again"));
            EXPECT_THAT(e.what(), ::testing::Not(HasSubstr("--resume to go on"))) << "resuming cannot help";
        }
        EXPECT_FALSE(std::filesystem::exists(output()));
    };
    // A finished stage-1 job's payloads, which the assembly reads.
    std::filesystem::path payloads;
    for (const auto& e : std::filesystem::directory_iterator(work() / "stage-1"))
        if (e.path().extension() == ".payloads") payloads = e.path();
    ASSERT_FALSE(payloads.empty());
    std::filesystem::resize_file(payloads, std::filesystem::file_size(payloads) - 1);
    fails_naming(payloads);
    // The plan.
    {
        std::fstream plan(work() / "plan", std::ios::in | std::ios::out | std::ios::binary);
        plan.seekp(40);
        plan.put('\x7f');
    }
    fails_naming(work() / "plan");
}

// A write that fails (a full disk: the error the job files throw) keeps what the plan made possible:
// after the plan, the finished jobs stay for --resume, and the message says so; before it, nothing does.
TEST_F(ResumeBuild, AFailedWriteKeepsTheFinishedJobsForResumeOnceThereIsAPlan) {
    auto build_failing_at = [&](const std::string& stage) {
        Progress progress;
        progress.report = [&](std::string_view now, double, double, std::string_view) {
            if (now == stage) throw std::runtime_error("cannot write the job file: No space left on device");
        };
        try {
            build(output(), small_settings(), progress);
            ADD_FAILURE() << "the build went on past a failed write in " << stage;
            return std::string();
        } catch (const std::runtime_error& e) {
            EXPECT_FALSE(std::filesystem::exists(output()));
            return std::string(e.what());
        }
    };
    const std::string early = build_failing_at("partition");
    EXPECT_THAT(early, HasSubstr("No space left on device"));
    EXPECT_THAT(early, ::testing::Not(HasSubstr("--resume")));
    EXPECT_FALSE(std::filesystem::exists(work())) << "a build that failed before its plan kept its work folder";

    const std::string late = build_failing_at("simplify level 3");
    EXPECT_THAT(late, HasSubstr("No space left on device"));
    EXPECT_THAT(late, HasSubstr("the finished blocks are kept in " + work().string() +
                                ": run the same command with --resume to go on"));
    ASSERT_TRUE(std::filesystem::exists(work() / "plan"));
    BuildSettings s = small_settings();
    s.resume = true;
    EXPECT_GT(build(output(), s).jobs_resumed, 0u);
    EXPECT_EQ(test::file_bytes(output()), test::file_bytes(reference()));
    EXPECT_FALSE(std::filesystem::exists(work()));
}

TEST_F(ResumeBuild, WithNothingToResumeItBuildsOrLeavesTheCompleteOutput) {
    BuildSettings s = small_settings();
    s.resume = true;
    const BuildReport fresh = build(output(), s);
    EXPECT_FALSE(fresh.resumed);
    EXPECT_EQ(test::file_bytes(output()), test::file_bytes(reference()));
    const auto written = std::filesystem::last_write_time(output());
    const BuildReport again = build(output(), s);
    EXPECT_TRUE(again.already_complete);
    EXPECT_EQ(std::filesystem::last_write_time(output()), written) << "a complete output was written again";
    EXPECT_EQ(test::file_bytes(output()), test::file_bytes(reference()));
}

TEST_F(ResumeBuild, ASecondBuildOfTheSameOutputIsRefusedWhileTheFirstRuns) {
    // The first build stops inside its first job stage until the second has tried.
    std::atomic<bool> tried{false}, inside{false};
    Progress holding;
    holding.report = [&](std::string_view stage, double, double, std::string_view) {
        if (stage != "level cubes" || inside.exchange(true)) return;
        while (!tried) std::this_thread::yield();
    };
    std::thread first([&] { build(output(), small_settings(), holding); });
    while (!inside) std::this_thread::yield();
    try {
        BuildSettings s = small_settings();
        s.resume = true;
        build(output(), s);
        ADD_FAILURE() << "two builds of one output ran at once";
    } catch (const InputError& e) {
        EXPECT_THAT(e.what(), HasSubstr("another build of this output is running"));
    }
    EXPECT_EQ(remove_build_leftovers(output(), {}), std::vector<std::filesystem::path>{}) << "--clean removed a running build's folder";
    tried = true;
    first.join();
    EXPECT_EQ(test::file_bytes(output()), test::file_bytes(reference()));
}

// The cluster's way: a plan, the jobs in ranges from two processes at once (each range split so that
// both run jobs of every stage, and overlapping so that some jobs run twice), then the assembly.
TEST_F(ResumeBuild, PlannedJobsRunInTwoProcessesAssembleToTheSameBytes) {
    const std::filesystem::path plan = dir_ / "plan";
    std::vector<std::string> warnings;
    const BuildSettings s = small_settings();
    const std::string jobs =
        plan_build(input_from_files({input()}, s.memory, {}, warnings), {input()}, plan, s, "sphere.ply");
    // "stage S LEVEL FIRST LAST ..." per stage
    std::vector<std::pair<uint64_t, uint64_t>> stages;
    std::istringstream lines(jobs);
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("stage ", 0) != 0) continue;
        std::istringstream fields(line.substr(6));
        uint64_t stage, level, first, last;
        fields >> stage >> level >> first >> last;
        stages.emplace_back(first, last);
    }
    ASSERT_EQ(stages.size(), 5u) << jobs;
    EXPECT_THROW(assemble_build(plan, output()), InputError) << "assembled before the jobs ran";
    EXPECT_THROW(run_build_jobs(plan, stages[1].first, stages[1].second, 1), InputError)
        << "ran stage 1 before stage 0";
    EXPECT_THROW(run_build_jobs(plan, 0, stages.back().second + 1, 1), InputError) << "ran jobs past the plan";
    for (const auto& [first, last] : stages) {
        const uint64_t middle = first + (last - first) / 2;
        const pid_t child = ::fork();
        if (child == 0) {
            try {
                run_build_jobs(plan, first, std::min(last, middle + 1), 1);
            } catch (...) {
                ::_exit(1);
            }
            ::_exit(0);
        }
        run_build_jobs(plan, middle, last, 1);
        int status = 0;
        ::waitpid(child, &status, 0);
        ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the other process's jobs " << first << "-" << middle;
    }
    const JobRunReport again = run_build_jobs(plan, 0, stages.back().second, 2);
    EXPECT_EQ(again.run, 0u) << "finished jobs ran again";
    assemble_build(plan, output());
    EXPECT_EQ(test::file_bytes(output()), test::file_bytes(reference()));
    EXPECT_FALSE(std::filesystem::exists(plan)) << "the assembly leaves the plan's folder";
}

}  // namespace
}  // namespace strata
