// strata verify FILE.hlod: check every invariant of the model; exit 1 naming the first violation.
#include "editor/commands.h"
#include "editor/progress_bar.h"
#include "preprocess/hlod_verify.h"

#include <cstdio>
#include <memory>

namespace strata::cli {
namespace {

int run_verify(const std::string& path, bool quiet) {
    ProgressBar bar(!quiet);
    HlodFile file(path);
    try {
        VerifyReport report = verify_hlod(file, bar.progress(install_interrupt_flag()));
        bar.finish();
        if (!quiet)
            std::printf("%s: ok: %llu cubes, %llu vertices, %llu triangles%s%s%s\n", path.c_str(),
                        (unsigned long long)report.cubes, (unsigned long long)report.vertices,
                        (unsigned long long)report.triangles, report.watertight ? ", every level closed" : "",
                        report.boundary_locked ? ", the boundary locked at every level" : "",
                        report.embedding ? ", its embedding sound" : "");
        return kOk;
    } catch (const Cancelled&) {
        bar.finish();
        std::fprintf(stderr, "strata verify: interrupted\n");
        return kInterrupted;
    }
}

}  // namespace

Command add_verify(CLI::App& app) {
    struct Options {
        std::string path;
        bool quiet = false;
    };
    auto o = std::make_shared<Options>();
    CLI::App* sub = app.add_subcommand("verify", "Check every invariant of a .hlod model (parent map, triangles, distance bounds, checksums; an embedding's section).");
    sub->add_option("file", o->path, "The .hlod file")->required();
    sub->add_flag("-q,--quiet", o->quiet, "Print nothing when the model is sound");
    return {sub, [o] { return run_verify(o->path, o->quiet); }};
}

}  // namespace strata::cli
