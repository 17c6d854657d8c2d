// strata build IN... -o OUT.hlod: read a scan (one file, or the tiles of one), build its HLOD model,
// write it.
#include "editor/commands.h"
#include "editor/progress_bar.h"
#include "preprocess/build_inputs.h"
#include "preprocess/byte_size.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/mesh_io.h"
#include "preprocess/parallel.h"
#include "preprocess/terrain_build.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

namespace strata::cli {
namespace {

struct BuildOptions {
    std::vector<std::string> inputs;
    std::string output, levels = "auto", memory, clean, plan, assemble;
    std::vector<std::string> run_blocks;  // DIR FIRST-LAST
    BuildSettings settings;
    TerrainSettings terrain;
    std::string fill_nodata;  // an elevation, or empty: nodata stays a hole
    std::string frame = "enu";
    std::string texture;  // an image to drape over a terrain
    std::vector<int> texture_bands;
    uint32_t texture_size = 0;
    bool quiet = false;
    bool verbose = false;
};

// FIRST-LAST, or one job number.
bool parse_job_range(const std::string& text, uint64_t& first, uint64_t& last) {
    const size_t dash = text.find('-');
    auto number = [](const std::string& digits, uint64_t& value) {
        if (digits.empty() || digits.size() > 18 || digits.find_first_not_of("0123456789") != std::string::npos) return false;
        value = std::stoull(digits);
        return true;
    };
    if (dash == std::string::npos) return number(text, first) && number(text, last);
    return number(text.substr(0, dash), first) && number(text.substr(dash + 1), last);
}

// strata build --run-blocks DIR FIRST-LAST: some of a planned build's jobs.
int run_jobs(const BuildOptions& o) {
    uint64_t first = 0, last = 0;
    if (!parse_job_range(o.run_blocks[1], first, last)) {
        std::fprintf(stderr, "strata build: --run-blocks takes a folder and a job range FIRST-LAST, not '%s'\n",
                     o.run_blocks[1].c_str());
        return kUsage;
    }
    const std::atomic<bool>* cancel = install_interrupt_flag();
    ProgressBar bar(!o.quiet);
    try {
        const JobRunReport report = run_build_jobs(o.run_blocks[0], first, last, o.settings.threads, bar.progress(cancel));
        bar.finish();
        if (!o.quiet)
            std::printf("%s: jobs %llu-%llu: %llu run, %llu had finished\n", o.run_blocks[0].c_str(), (unsigned long long)first,
                        (unsigned long long)last, (unsigned long long)report.run, (unsigned long long)report.already_finished);
        return kOk;
    } catch (const Cancelled&) {
        bar.finish();
        std::fprintf(stderr, "strata build: interrupted; the jobs that finished are kept in %s\n", o.run_blocks[0].c_str());
        return kInterrupted;
    }
}

void print_levels(const BuildReport& report) {
    for (const LevelStats& l : report.levels)
        std::printf("  level %2u: %7llu cubes %11llu vertices %11llu triangles %10.2f MB\n", l.level,
                    (unsigned long long)l.cubes, (unsigned long long)l.vertices, (unsigned long long)l.triangles, l.bytes / 1e6);
}

// strata build --assemble DIR -o OUT: the model from a planned build's finished jobs.
int run_assemble(const BuildOptions& o) {
    if (o.output.empty()) {
        std::fprintf(stderr, "strata build: --assemble needs --output\n");
        return kUsage;
    }
    const std::atomic<bool>* cancel = install_interrupt_flag();
    ProgressBar bar(!o.quiet);
    try {
        const BuildReport report = assemble_build(o.assemble, o.output, bar.progress(cancel));
        bar.finish();
        if (!o.quiet)
            std::printf("%s: %llu triangles, %u levels, σ0 %.3g, ε_q %.3g, %.1f MB, from %llu jobs\n", o.output.c_str(),
                        (unsigned long long)report.input_triangles, report.max_level + 1, report.sigma0, report.error_q,
                        report.output_bytes / 1e6, (unsigned long long)report.jobs);
        if (o.verbose) print_levels(report);
        return kOk;
    } catch (const Cancelled&) {
        bar.finish();
        std::fprintf(stderr, "strata build: interrupted; %s was not written\n", o.output.c_str());
        return kInterrupted;
    }
}

// strata build --clean OUT.hlod: what killed builds of OUT.hlod left.
int run_clean(const BuildOptions& o) {
    if (!o.inputs.empty() || !o.output.empty()) {
        std::fprintf(stderr, "strata build: --clean takes the output's path alone, not inputs or -o\n");
        return kUsage;
    }
    for (const std::filesystem::path& p : remove_build_leftovers(o.clean, o.settings.temp_dir))
        if (!o.quiet) std::printf("removed %s\n", p.c_str());
    return kOk;
}

// strata build DEM... -o OUT.hlod: a terrain straight from elevation rasters, in `memory` bytes.
int run_terrain(const BuildOptions& o, const std::vector<std::filesystem::path>& files, uint64_t memory) {
    if (!o.plan.empty() || o.settings.resume) {
        std::fprintf(stderr, "strata build: --plan and --resume build meshes; a terrain builds in one run\n");
        return kUsage;
    }
    if (o.settings.lock_boundary) {
        std::fprintf(stderr, "strata build: --lock-boundary locks a mesh's open boundary, for embedding it in a terrain; "
                             "%s is an elevation raster\n", files.front().c_str());
        return kUsage;
    }
    TerrainSettings settings = o.terrain;
    settings.threads = o.settings.threads;
    try {
        set_frame(settings, o.frame);
    } catch (const InputError& e) {
        std::fprintf(stderr, "strata build: %s\n", e.what());
        return kUsage;
    }
    if (!o.fill_nodata.empty()) {
        char* end = nullptr;
        const float value = std::strtof(o.fill_nodata.c_str(), &end);
        if (*end || !std::isfinite(value)) {
            std::fprintf(stderr, "strata build: --fill-nodata takes an elevation in metres, not '%s'\n", o.fill_nodata.c_str());
            return kUsage;
        }
        settings.fill = value;
    }
    settings.memory = memory;
    if (!o.texture.empty()) settings.texture = TextureSettings{o.texture, o.texture_bands, o.texture_size};
    const std::atomic<bool>* cancel = install_interrupt_flag();
    ProgressBar bar(!o.quiet);
    const auto start = std::chrono::steady_clock::now();
    try {
        const BuildReport report = build_terrain(files, o.output, settings, source_name(o.inputs, files.size()), bar.progress(cancel));
        bar.finish();
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (!o.quiet)
            std::printf("%s: terrain, %llu triangles, %u levels, σ0 %.3g, ε_q %.3g, %.1f MB, %.2f s\n", o.output.c_str(),
                        (unsigned long long)report.input_triangles, report.max_level + 1, report.sigma0, report.error_q,
                        report.output_bytes / 1e6, seconds);
        if (!o.quiet)
            for (const std::string& note : report.notes) std::fprintf(stderr, "strata build: note: %s\n", note.c_str());
        if (o.verbose) {
            print_levels(report);
            std::printf("  heights: on a %.3g m lattice at level %u, within %.3g m of the raster's (--height-tolerance)\n",
                        report.height_quantum, report.max_level, report.height_quantum / 2);
            std::printf("  seconds: read %.2f, tiles %.2f, coarse levels %.2f, write %.2f (textures %.2f)\n", report.read_seconds,
                        report.partition_seconds, report.simplify_seconds, report.write_seconds, report.texture_seconds);
            if (report.texture_size)
                std::printf("  textures: %u × %u texels a cube, %s\n", report.texture_size, report.texture_size,
                            describe_bytes(report.texture_bytes).c_str());
            std::printf("  memory: %s at most\n", describe_bytes(peak_resident_bytes()).c_str());
        }
        return kOk;
    } catch (const Cancelled&) {
        bar.finish();
        std::fprintf(stderr, "strata build: interrupted; %s was not written\n", o.output.c_str());
        return kInterrupted;
    }
}

int run_build(const BuildOptions& o) {
    const int modes = !o.clean.empty() + !o.plan.empty() + !o.run_blocks.empty() + !o.assemble.empty();
    if (modes > 1) {
        std::fprintf(stderr, "strata build: --clean, --plan, --run-blocks and --assemble exclude each other\n");
        return kUsage;
    }
    if (!o.clean.empty()) return run_clean(o);
    if (!o.run_blocks.empty() || !o.assemble.empty()) {
        if (!o.inputs.empty()) {
            std::fprintf(stderr, "strata build: --run-blocks and --assemble read the plan's folder, not inputs\n");
            return kUsage;
        }
        return o.assemble.empty() ? run_jobs(o) : run_assemble(o);
    }
    if (o.inputs.empty()) {
        std::fprintf(stderr, "strata build: input is required (or --clean OUT.hlod)\n");
        return kUsage;
    }
    if (o.output.empty() == o.plan.empty()) {
        std::fprintf(stderr, o.plan.empty() ? "strata build: --output is required\n"
                                            : "strata build: --plan writes a plan, not --output (that is --assemble's)\n");
        return kUsage;
    }
    BuildSettings settings = o.settings;
    if (o.levels != "auto") {
        try {
            size_t used = 0;
            settings.levels = std::stoi(o.levels, &used);
            if (used != o.levels.size()) throw std::invalid_argument(o.levels);
        } catch (const std::exception&) {
            std::fprintf(stderr, "strata build: --levels takes 'auto' or a number, not '%s'\n", o.levels.c_str());
            return kUsage;
        }
    }
    uint64_t memory_limit = default_memory_limit();
    std::string limit_name = "the default --memory, a quarter of physical memory";
    if (!o.memory.empty()) {
        try {
            memory_limit = parse_byte_size(o.memory);
            limit_name = "--memory " + o.memory;
        } catch (const std::invalid_argument& e) {
            std::fprintf(stderr, "strata build: --memory: %s\n", e.what());
            return kUsage;
        }
    }
    settings.memory = memory_limit;
    try {
        check_settings(settings);
    } catch (const InputError& e) {
        std::fprintf(stderr, "strata build: %s\n", e.what());
        return kUsage;
    }
    const std::vector<std::filesystem::path> files = expand_inputs(o.inputs);
    if (std::all_of(files.begin(), files.end(), is_elevation_raster)) return run_terrain(o, files, memory_limit);
    if (!o.texture.empty() || !o.texture_bands.empty() || o.texture_size) {
        std::fprintf(stderr, "strata build: --texture, --texture-bands and --texture-size drape imagery over a terrain; a mesh keeps its own texture\n");
        return kUsage;
    }
    const MemoryEstimate estimate = estimate_build(files, memory_limit);
    const std::filesystem::path temp = o.plan.empty() ? temp_folder(o.output, o.settings.temp_dir) : std::filesystem::path(o.plan);
    if (o.verbose) {
        std::printf("  memory: about %s for %llu%s triangles in %zu file%s, %llu of them read whole into memory (limit %s)\n",
                    describe_bytes(estimate.bytes).c_str(), (unsigned long long)estimate.triangles,
                    estimate.guessed ? " (estimated)" : "", files.size(), files.size() == 1 ? "" : "s",
                    (unsigned long long)estimate.in_memory_triangles, describe_bytes(memory_limit).c_str());
        std::printf("  temporary disk: about %s in %s\n", describe_bytes(estimate.temp_bytes).c_str(), temp.c_str());
        const unsigned threads = resolve_thread_count(settings.threads);
        std::printf("  time: about %s on %u thread%s (with the cores and the disk to itself)\n",
                    describe_duration(estimate.cpu_seconds / threads).c_str(), threads, threads == 1 ? "" : "s");
    }
    check_memory(estimate, memory_limit, limit_name);
    check_temp_disk(estimate, temp, settings.resume ? leftover_bytes(o.output, o.settings.temp_dir) : 0);
    const std::atomic<bool>* cancel = install_interrupt_flag();
    ProgressBar bar(!o.quiet);
    Progress progress = bar.progress(cancel);
    auto start = std::chrono::steady_clock::now();
    std::vector<std::string> warnings;
    // The readers' warnings, printed once the input is open, on a line of their own.
    const OpenInput read_input = [&, open = input_from_files(files, memory_limit, progress, warnings)] {
        BuildInput input = open();
        bar.finish();  // clears the bar's line; the next report draws it again
        for (const std::string& warning : warnings) std::fprintf(stderr, "strata build: warning: %s\n", warning.c_str());
        return input;
    };
    const std::string name = source_name(o.inputs, files.size());
    try {
        if (!o.plan.empty()) {
            const std::string jobs = plan_build(read_input, files, o.plan, settings, name, progress);
            bar.finish();
            if (!o.quiet) std::printf("%s: planned; run its jobs (listed in %s/jobs.txt):\n%s", o.plan.c_str(), o.plan.c_str(), jobs.c_str());
            return kOk;
        }
        BuildReport report = build_hlod(read_input, files, o.output, settings, name, progress);
        bar.finish();
        if (report.already_complete) {
            if (!o.quiet) std::printf("%s: complete; nothing to resume\n", o.output.c_str());
            return kOk;
        }
        const uint64_t triangles = report.input_triangles;
        double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        for (const std::string& note : report.notes) std::fprintf(stderr, "strata build: note: %s\n", note.c_str());
        if (!o.quiet && report.resumed)
            std::printf("%s: resumed, %llu of its %llu jobs had finished\n", o.output.c_str(),
                        (unsigned long long)report.jobs_resumed, (unsigned long long)report.jobs);
        if (!o.quiet)
            std::printf("%s: %llu triangles, %u levels, σ0 %.3g, ε_q %.3g, %.1f MB, %.2f s (%.2f M triangles/s)\n",
                        o.output.c_str(), (unsigned long long)triangles, report.max_level + 1, report.sigma0, report.error_q,
                        report.output_bytes / 1e6, seconds, triangles / seconds / 1e6);
        if (!o.quiet && settings.lock_boundary)
            std::printf("%s: the open boundary's %llu points locked at every level\n", o.output.c_str(),
                        (unsigned long long)report.boundary_points);
        if (o.verbose) {
            print_levels(report);
            std::printf("  seconds: read %.2f, partition %.2f, simplify %.2f, write %.2f\n", report.read_seconds,
                        report.partition_seconds, report.simplify_seconds, report.write_seconds);
            std::printf("  temporary disk: %s at most\n", describe_bytes(report.temp_bytes).c_str());
            std::printf("  memory: %s at most (largest input %s, triangle spill %s, border listings %s)\n",
                        describe_bytes(peak_resident_bytes()).c_str(), describe_bytes(report.source_memory_bytes).c_str(),
                        describe_bytes(report.spill_memory_bytes).c_str(), describe_bytes(report.border_bytes).c_str());
        }
        return kOk;
    } catch (const Cancelled&) {
        bar.finish();
        std::fprintf(stderr, "strata build: interrupted; %s was not written\n", o.output.c_str());
        return kInterrupted;
    }
}

}  // namespace

Command add_build(CLI::App& app) {
    auto o = std::make_shared<BuildOptions>();
    CLI::App* sub = app.add_subcommand("build", "Build a multiresolution model (.hlod) from a scan (PLY, OBJ, OFF, STL), or a terrain from elevation rasters (GeoTIFF or any DEM GDAL reads).");
    sub->add_option("input", o->inputs,
                    "The scan: one file, or the tiles of one model (welded along shared borders), or for a terrain one "
                    "elevation raster or the tiles of one grid; @LIST reads "
                    "the inputs from a text file, one per line (# comments; relative to the list's folder)");
    sub->add_option("-o,--output", o->output, "The .hlod file to write");
    sub->add_flag("--resume", o->settings.resume,
                  "Go on from what a killed or failed build of this output left (its finished blocks), making the "
                  "same bytes; refused, naming it, when a setting that changes the output (levels, block, ratio, "
                  "sigma0, error, lock-boundary) or an input differs. With nothing to resume it builds, or leaves a "
                  "complete output");
    sub->add_option("--plan", o->plan,
                    "Instead of building: read the input into DIR (new or empty) and list the build's jobs in "
                    "DIR/jobs.txt, for a cluster (--run-blocks, then --assemble)")
        ->type_name("DIR");
    sub->add_option("--run-blocks", o->run_blocks,
                    "Instead of building: run jobs FIRST-LAST of the plan in DIR (jobs of one stage need the stages "
                    "before them finished); safe to run again, or twice at once")
        ->expected(2)
        ->type_name("DIR FIRST-LAST");
    sub->add_option("--assemble", o->assemble, "Instead of building: write --output from the finished jobs in DIR, then remove DIR")
        ->type_name("DIR");
    sub->add_option("--clean", o->clean,
                    "Instead of building: remove what killed or failed builds of this output left (its work folder "
                    "in --temp or beside it, temporary output files), keeping a running build's");
    sub->add_option("--levels", o->levels, "L, the finest level: 'auto' (a leaf holds a few thousand triangles) or a number")
        ->capture_default_str();
    sub->add_option("--block", o->settings.block, "Cubes per block side (a multiple of 4)")->capture_default_str();
    sub->add_option("--ratio", o->settings.ratio, "Triangles kept from one level to the next")->capture_default_str();
    sub->add_option("--sigma0", o->settings.sigma0, "Least σ0 (vertex travel bound, in cube sizes); raised if the input's edges need more")
        ->capture_default_str();
    sub->add_option("--error", o->settings.error, "Stop simplifying a level at this error, relative to the cube size (ε_q)");
    sub->add_flag("--lock-boundary", o->settings.lock_boundary,
                  "For a mesh to embed in a terrain: keep its open boundary (the edges an odd number of triangles "
                  "use: one, on a surface) at every level, never simplified, each of its vertices on the coarsest "
                  "level's lattice (within 2^-16 of the model's size of where it was), so every level draws the "
                  "finest level's boundary to the bit");
    sub->add_option("--threads", o->settings.threads, "Worker threads (0: every core)")->capture_default_str();
    sub->add_option("--memory", o->memory,
                    "Memory for the build's buffers and any input read whole, in bytes or with a binary suffix K, M, "
                    "G, T (2G, 512M, 1.5G); at least 16M, default a quarter of physical memory. Peak memory stays "
                    "under it plus a fixed overhead (about 150 MiB). Binary PLY streams from disk; other formats "
                    "are read whole, and a build estimated not to fit is refused before reading. A terrain larger than "
                    "half of it is built in tiles. Never changes the output");
    sub->add_option("--temp", o->settings.temp_dir,
                    "Folder for the build's work folder OUT.build (the input's triangles sorted by block, then "
                    "each level's cubes and shared border points; about 40 bytes per input triangle at the peak); "
                    "default beside the output. Removed when the build succeeds, is interrupted or meets bad "
                    "input; kept after a kill or another failure, for --resume");
    sub->add_option("--crs", o->terrain.crs, "Terrains: the CRS of elevation rasters that declare none (EPSG:N, WKT or PROJ)");
    sub->add_option("--elevation-unit", o->terrain.elevation_unit,
                    "Terrains: the unit of elevations when the raster does not say: m, ft or us-ft (default m)")
        ->check(CLI::IsMember({"m", "ft", "us-ft"}));
    sub->add_option("--frame", o->frame,
                    "Terrains in degrees: enu (a flat tangent plane at the centre, heights up) or ecef (the Earth's curvature kept); "
                    "or any terrain: a projected CRS in metres (EPSG:N, WKT or PROJ) to reproject it into")
        ->capture_default_str();
    sub->add_option("--cube-cells", o->terrain.cube_cells,
                    "Terrains: cells along a cube's side (even, 8 to 256): larger for very steep ground")
        ->check(CLI::Range(8u, 256u))
        ->check([](const std::string& value) { return std::stoul(value) % 2 ? std::string("an even number of cells") : std::string(); })
        ->capture_default_str();
    sub->add_option("--height-tolerance", o->terrain.height_tolerance,
                    "Terrains: how far (metres) a vertex's height may move from the raster's value, to store it in fewer bits "
                    "(each cube's error bound includes it; height_at stays exact); default 1/128 of the sample spacing, 0: finest")
        ->check(CLI::Range(0.0, 1e6));
    sub->add_option("--fill-nodata", o->fill_nodata,
                    "Terrains: give nodata samples this elevation (metres) instead of leaving holes");
    sub->add_option("--texture", o->texture,
                    "Terrains: an image to drape over the ground (an orthophoto GDAL reads, RGB or grey, 8- or 16-bit, "
                    "in any CRS), stored as per-cube BC1 textures");
    sub->add_option("--texture-bands", o->texture_bands, "Terrains: the image's bands that give red, green, blue (default 1,2,3; one band: grey)")
        ->delimiter(',')
        ->check(CLI::Range(1, 65535));
    sub->add_option("--texture-size", o->texture_size,
                    "Terrains: texels along a cube's texture (a power of two, 8 to 4096); default: as fine as the image, at most 1024")
        ->check([](const std::string& value) {
            return TextureLayout::valid_size(uint32_t(std::min(std::stoul(value), 1ul << 20))) ? std::string() : std::string("a power of two from 8 to 4096");
        });
    sub->add_flag("-q,--quiet", o->quiet, "No progress bar and no summary");
    sub->add_flag("-v,--verbose", o->verbose, "Also print the memory, temporary-disk and time estimates, each level's counts, each stage's time, and the peak temporary disk and memory");
    return {sub, [o] { return run_build(*o); }};
}

}  // namespace strata::cli
