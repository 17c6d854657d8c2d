// The fidelity benchmark (issue 15 §3, DESIGN.md §6): an HLOD model against its full mesh over seeded
// views (far, oblique, close, grazing, orthographic; tests/support/fidelity.h) at 1280×720, for each
// pixel error asked: triangles drawn per covered pixel, frame times, the share of drawn cubes per
// level, and the screen-space error measured per covered pixel, both ways. Medians over the views;
// "worst" is over every pixel of every view. Asserts nothing.
//
//   bench_fidelity [--model M.hlod --mesh M.ply] [--views 50] [--size 1280x720] [--pixel-error 1,4,16]
//                  [--threads N]
//
// Without --model and --mesh it builds the bundled scan (data/bunny.off, levels 0 … 3, as the tests do).
// A frame's time is from the start of culling to glFinish() returning, one sample per pixel.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "engine/gl/context.h"
#include "preprocess/mesh_io.h"
#include "tests/bench/bench_stats.h"
#include "tests/support/bunny_model.h"
#include "tests/support/fidelity.h"

namespace {

using strata::test::FidelityReport;
using strata::test::PixelErrors;

using strata::bench::median;

template <class Field>
double median_of(const std::vector<FidelityReport>& reports, Field field) {
    std::vector<double> values;
    for (const FidelityReport& r : reports) values.push_back(double(field(r)));
    return median(values);
}

struct Options {
    std::string model, mesh;
    int views = 50, width = 1280, height = 720;
    std::vector<double> pixel_errors{1.0};
    unsigned threads = 0;
};

bool parse(int argc, char** argv, Options& o) {
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : ""; };
        if (a == "--model") o.model = next();
        else if (a == "--mesh") o.mesh = next();
        else if (a == "--views") o.views = std::atoi(next());
        else if (a == "--threads") o.threads = unsigned(std::atoi(next()));
        else if (a == "--pixel-error") {
            o.pixel_errors.clear();
            std::stringstream list(next());
            for (std::string item; std::getline(list, item, ',');) o.pixel_errors.push_back(std::atof(item.c_str()));
        } else if (a == "--size") {
            if (std::sscanf(next(), "%dx%d", &o.width, &o.height) != 2) return false;
        } else return false;
    }
    const bool pixel_errors_ok = !o.pixel_errors.empty() &&
                                 std::all_of(o.pixel_errors.begin(), o.pixel_errors.end(), [](double p) { return p > 0; });
    return o.model.empty() == o.mesh.empty() && o.views > 0 && pixel_errors_ok;
}

// One direction's medians over the views, and the worst pixel and the share within P over all of them.
void print_errors(const char* name, const std::vector<FidelityReport>& reports, const PixelErrors FidelityReport::*which) {
    size_t pixels = 0, within = 0;
    double worst = 0;
    for (const FidelityReport& r : reports) {
        pixels += (r.*which).pixels;
        within += (r.*which).within;
        worst = std::max(worst, (r.*which).max);
    }
    std::printf("  %-9s p50 %.3g  p99 %.3g  p99.9 %.3g  max %.3g px   worst %.3g px, %.3f %% of %zu pixels within P\n", name,
                median_of(reports, [&](const FidelityReport& r) { return (r.*which).p50; }),
                median_of(reports, [&](const FidelityReport& r) { return (r.*which).p99; }),
                median_of(reports, [&](const FidelityReport& r) { return (r.*which).p999; }),
                median_of(reports, [&](const FidelityReport& r) { return (r.*which).max; }), worst,
                pixels ? 100.0 * double(within) / double(pixels) : 100.0, pixels);
}

void print_pass(double pixel_error, const std::vector<FidelityReport>& reports, const Options& o) {
    std::printf("\nP = %g px, %zu views at %dx%d (medians over views)\n", pixel_error, reports.size(), o.width, o.height);
    std::printf("  %-28s %14s %14s\n", "", "HLOD", "full mesh");
    std::printf("  %-28s %14.0f %14.0f\n", "triangles drawn", median_of(reports, [](auto& r) { return r.hlod_triangles; }),
                median_of(reports, [](auto& r) { return r.full_triangles; }));
    std::printf("  %-28s %14.0f %14.0f\n", "covered pixels", median_of(reports, [](auto& r) { return r.forward.pixels; }),
                median_of(reports, [](auto& r) { return r.backward.pixels; }));
    auto per_pixel = [](uint64_t triangles, size_t pixels) { return pixels ? double(triangles) / double(pixels) : 0.0; };
    std::printf("  %-28s %14.3f %14.3f\n", "triangles per covered pixel",
                median_of(reports, [&](auto& r) { return per_pixel(r.hlod_triangles, r.forward.pixels); }),
                median_of(reports, [&](auto& r) { return per_pixel(r.full_triangles, r.backward.pixels); }));
    std::printf("  %-28s %14.2f %14.2f\n", "frame (ms, to glFinish)", median_of(reports, [](auto& r) { return r.hlod_frame_ms; }),
                median_of(reports, [](auto& r) { return r.full_frame_ms; }));
    std::vector<double> cubes(reports.front().cubes_per_level.size(), 0.0);
    double total = 0;
    for (const FidelityReport& r : reports)
        for (size_t l = 0; l < cubes.size(); ++l) {
            cubes[l] += r.cubes_per_level[l];
            total += r.cubes_per_level[l];
        }
    std::printf("  cubes drawn per level (all views):");
    for (size_t l = 0; l < cubes.size(); ++l) std::printf("  L%zu %.1f %%", l, total ? 100 * cubes[l] / total : 0.0);
    std::printf("\n  screen-space error:\n");
    print_errors("forward", reports, &FidelityReport::forward);
    print_errors("backward", reports, &FidelityReport::backward);
    print_errors("noise", reports, &FidelityReport::noise);
    std::printf("  measurement: %.0f ms per view (CPU, after read-back)\n", median_of(reports, [](auto& r) { return r.measure_ms; }));
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    if (!parse(argc, argv, o)) {
        std::fprintf(stderr, "usage: bench_fidelity [--model FILE.hlod --mesh FILE] [--views N] [--size WxH] "
                             "[--pixel-error P[,P...]] [--threads N]\n");
        return 2;
    }
    try {
        if (o.model.empty()) {
            o.model = strata::test::bunny_hlod().string();
            o.mesh = (std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "bunny.off").string();
            if (o.model.empty()) throw std::runtime_error("data/bunny.off missing: run scripts/setup.sh, or give --model and --mesh");
        }
        auto context = strata::gl::create_headless_context();
        std::printf("device: %s\nmodel: %s\nmesh: %s\n", context->renderer().c_str(), o.model.c_str(), o.mesh.c_str());
        auto model = strata::HlodModel::load(o.model);
        const strata::Mesh mesh = strata::read_mesh(o.mesh);
        strata::test::FidelityMeter meter(model, mesh, o.threads);
        const auto views = strata::test::fidelity_views(model->bound(), mesh, o.views, o.width, o.height, 11);
        for (const double p : o.pixel_errors) {
            model->set_pixel_error(p);
            meter.measure(*views.front(), p);  // uploads and warms up
            std::vector<FidelityReport> reports;
            for (const auto& camera : views) reports.push_back(meter.measure(*camera, p));
            print_pass(p, reports, o);
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_fidelity: %s\n", e.what());
        return 1;
    }
    return 0;
}
