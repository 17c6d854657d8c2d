// Binary PLY read speed: read_mesh() (parse + weld) on a generated grid, median of 5 runs.
//
//   bench_ply_read [TRIANGLES] [PATH]
//
// TRIANGLES defaults to 20 million. Without PATH the file goes to a temporary directory and is removed
// afterwards; with PATH it is generated there and kept, or, if PATH already exists, read as it is
// (any mesh file). The file is read once untimed first, so the runs measure parsing from the page cache,
// not the disk. Prints figures only.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "preprocess/mesh_io.h"

namespace {

// A W x H grid of quads over a gently waving surface, cut to exactly `triangles` triangles.
strata::Mesh grid_mesh(size_t triangles) {
    const size_t w = std::max<size_t>(1, size_t(std::ceil(std::sqrt(double(triangles) / 2))));
    const size_t h = (triangles + 2 * w - 1) / (2 * w);
    strata::Mesh mesh;
    mesh.positions.reserve(3 * (w + 1) * (h + 1));
    for (size_t y = 0; y <= h; ++y)
        for (size_t x = 0; x <= w; ++x)
            mesh.positions.insert(mesh.positions.end(),
                                  {float(x), float(y), 0.25f * std::sin(0.1f * float(x)) * std::cos(0.1f * float(y))});
    mesh.indices.reserve(3 * triangles);
    auto at = [w](size_t x, size_t y) { return uint32_t(y * (w + 1) + x); };
    for (size_t y = 0; y < h; ++y) {
        for (size_t x = 0; x < w; ++x) {
            mesh.indices.insert(mesh.indices.end(), {at(x, y), at(x + 1, y), at(x + 1, y + 1)});
            mesh.indices.insert(mesh.indices.end(), {at(x, y), at(x + 1, y + 1), at(x, y + 1)});
        }
    }
    mesh.indices.resize(3 * triangles);
    return mesh;
}

double seconds_to_read(const std::filesystem::path& path, size_t& triangles, size_t& vertices) {
    const auto start = std::chrono::steady_clock::now();
    strata::Mesh mesh = strata::read_mesh(path);
    const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
    triangles = mesh.triangle_count();
    vertices = mesh.vertex_count();
    return elapsed.count();
}

}  // namespace

int main(int argc, char** argv) {
    const size_t triangles = argc > 1 ? size_t(std::strtoull(argv[1], nullptr, 10)) : size_t(20'000'000);
    std::filesystem::path dir;
    std::filesystem::path path;
    if (argc > 2) {
        path = argv[2];
    } else {
        dir = std::filesystem::temp_directory_path() / ("strata_bench_ply_" + std::to_string(::getpid()));
        std::filesystem::create_directories(dir);
        path = dir / "grid.ply";
    }
    try {
        if (!std::filesystem::exists(path)) {
            std::printf("generating %zu triangles into %s\n", triangles, path.c_str());
            strata::write_ply(path, grid_mesh(triangles));
        }
        const double megabytes = double(std::filesystem::file_size(path)) / 1e6;
        size_t read_triangles = 0, read_vertices = 0;
        seconds_to_read(path, read_triangles, read_vertices);  // warm the page cache
        std::vector<double> runs;
        for (int run = 0; run < 5; ++run) runs.push_back(seconds_to_read(path, read_triangles, read_vertices));
        std::sort(runs.begin(), runs.end());
        const double median = runs[runs.size() / 2];
        std::printf("file: %s, %.1f MB, %zu vertices, %zu triangles after weld\n", path.c_str(), megabytes,
                    read_vertices, read_triangles);
        std::printf("read_mesh median of 5: %.3f s  (min %.3f, max %.3f)\n", median, runs.front(), runs.back());
        std::printf("%.0f MB/s  %.1f Mtri/s\n", megabytes / median, double(read_triangles) / 1e6 / median);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_ply_read: %s\n", e.what());
        if (!dir.empty()) std::filesystem::remove_all(dir);
        return 1;
    }
    if (!dir.empty()) std::filesystem::remove_all(dir);
    return 0;
}
