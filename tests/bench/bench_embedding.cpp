// The embedding's preprocessing in raster space, one thread, median of 5 runs: the footprint (boundary
// loops, the ring's self-crossing check) and the skirt (zone covers, the ring split at grid lines, cut
// cells ear-clipped) for a synthetic boundary ring of VERTICES vertices wiggling around a circle of
// RADIUS raster cells (a scan's boundary is far denser than a DEM: thousands of vertices a cell), the
// zone's cells ZONE finest cells wide.
//
//   bench_embedding [VERTICES [RADIUS [ZONE]]]      (defaults 100000 20 4)
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "preprocess/skirt.h"
#include "tests/bench/bench_stats.h"

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) try {
    using namespace strata;
    const int vertices = argc > 1 ? std::atoi(argv[1]) : 100000;
    const double radius = argc > 2 ? std::atof(argv[2]) : 20;
    const int64_t zone_cells = argc > 3 ? std::atoll(argv[3]) : 4;
    if (vertices < 3 || !(radius > 0) || zone_cells < 1) {
        std::fprintf(stderr, "usage: bench_embedding [VERTICES >= 3 [RADIUS > 0 [ZONE >= 1]]]\n");
        return 2;
    }
    // A fan whose rim wiggles at two scales, like a scan's ragged edge.
    Mesh mesh;
    const double centre = radius * 1.2 + 2 * double(zone_cells);
    for (int i = 0; i < vertices; ++i) {
        const double a = 2 * M_PI * i / vertices, r = radius * (1 + 0.05 * std::sin(a * 37) + 0.01 * std::sin(a * 1009));
        mesh.positions.insert(mesh.positions.end(), {float(centre + r * std::cos(a)), float(centre + r * std::sin(a)), 0.0f});
    }
    mesh.positions.insert(mesh.positions.end(), {float(centre), float(centre), 1.0f});
    for (uint32_t i = 0; i < uint32_t(vertices); ++i) mesh.indices.insert(mesh.indices.end(), {uint32_t(vertices), i, (i + 1) % uint32_t(vertices)});
    const int64_t size = int64_t(2 * centre) + 1;

    std::vector<double> footprint_seconds, skirt_seconds;
    Skirt skirt;
    for (int run = 0; run < 5; ++run) {
        auto start = std::chrono::steady_clock::now();
        const Footprint footprint = make_footprint(mesh, [](const glm::dvec3& p) { return glm::dvec2(p.x, p.y); }, size, size, "ring");
        footprint_seconds.push_back(seconds_since(start));
        start = std::chrono::steady_clock::now();
        skirt = build_skirt(footprint, classify_cells(footprint.points, zone_cells, size, size), size, size, "ring");
        skirt_seconds.push_back(seconds_since(start));
    }
    size_t crossings = 0;
    for (const SkirtVertex& v : skirt.vertices) crossings += v.kind == SkirtVertex::Kind::crossing;
    std::printf("ring of %d vertices, radius %.1f cells, zone cells of %lld: %zu cut cells (%.0f vertices each)\n", vertices, radius,
                (long long)zone_cells, skirt.cut_cells, double(vertices) / double(std::max<size_t>(skirt.cut_cells, 1)));
    std::printf("footprint %.3f s, skirt %.3f s (medians of 5, one thread); skirt %zu triangles, %zu vertices, crossings %.2f%% of the ring\n",
                bench::median(footprint_seconds), bench::median(skirt_seconds), skirt.triangles.size() / 3, skirt.vertices.size(),
                100.0 * double(crossings) / vertices);
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "bench_embedding: %s\n", e.what());
    return 1;
}
