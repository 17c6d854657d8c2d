// The builder benchmark (issue 2 §6): a ≥ 19 M-triangle mesh derived from a real scan, built end to
// end by the real `strata build` (read → .hlod) in a child process, against one meshopt_simplify pass
// of the same mesh to a quarter. Prints figures beside their targets; asserts nothing.
//
//   bench_build [--scan data/bunny.off] [--splits 16] [--runs 3] [--threads 0] [--no-meshopt] [--keep DIR] [--derive-only]
//   bench_build --dem data/trinidad.nc[:STRIDE] [--dem-unit feet|metres] [--runs 3] ...
//
// The derived mesh is four midpoint subdivisions of the scan (each triangle split 16 ways along its
// edges, the same points) with a small deterministic displacement along the normal, written as binary
// PLY once (streamed: memory stays that of the scan at any size) and reused from DIR; --derive-only
// stops there. With --dem the mesh is instead a real terrain: the netCDF DEM's grid (every STRIDE-th
// sample, default 1) as tests/support/dem_grid.h reads it, its elevations in the unit --dem-unit names
// (default: its units attribute; trinidad.nc's feet are not marked), written as binary PLY once.
#include "preprocess/atomic_file.h"
#include "preprocess/mesh_io.h"
#include "tests/bench/bench_stats.h"
#include "tests/support/dem_grid.h"

#include <meshoptimizer.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

using strata::bench::median;

uint32_t hash32(uint64_t x) {
    x ^= x >> 33, x *= 0xff51afd7ed558ccdull, x ^= x >> 33, x *= 0xc4ceb9fe1a85ec53ull, x ^= x >> 33;
    return uint32_t(x);
}

// Splits every triangle into n² along a regular grid of its edges (n = 16: four midpoint subdivisions),
// sharing the points on edges between neighbours so a closed scan stays closed; then moves every new
// point along the interpolated normal by up to `bump` of the fine edge length. The result is written
// as it is made: only the scan and its edge table are held, so a billion-triangle mesh needs no more
// memory than the scan. Point ids: the scan's points, then each input edge's inner points (edges in
// order of first use, points from the edge's smaller vertex), then each triangle's inner points.
class Subdivision {
public:
    Subdivision(const strata::Mesh& in, int n, float bump) : in_(in), n_(n) {
        const size_t F = in.triangle_count();
        // Edges of the input, each with an id, found by sorting (min, max) pairs.
        std::vector<std::pair<uint64_t, uint32_t>> half(3 * F);
        for (size_t t = 0; t < F; ++t)
            for (int e = 0; e < 3; ++e) {
                uint64_t a = in.indices[3 * t + e], b = in.indices[3 * t + (e + 1) % 3];
                half[3 * t + e] = {std::min(a, b) << 32 | std::max(a, b), uint32_t(3 * t + e)};
            }
        std::sort(half.begin(), half.end());
        edge_of_.resize(3 * F);
        uint32_t edges = 0;
        for (size_t i = 0; i < half.size(); ++i) {
            if (i > 0 && half[i].first != half[i - 1].first) ++edges;
            edge_of_[half[i].second] = edges;
        }
        ++edges;
        // The edges in order of first use (each by the half-edge that first uses it), and each edge's
        // first inner point in that order.
        edge_first_.assign(edges, ~uint64_t(0));
        uint64_t next = in.vertex_count();
        for (size_t h = 0; h < 3 * F; ++h)
            if (edge_first_[edge_of_[h]] == ~uint64_t(0)) {
                edge_first_[edge_of_[h]] = next, next += n - 1;
                first_uses_.push_back(uint32_t(h));
            }
        interior_first_ = next;

        // Smooth input normals, for the displacement direction.
        normal_.assign(3 * in.vertex_count(), 0.0f);
        for (size_t t = 0; t < F; ++t) {
            const float* p[3];
            for (int c = 0; c < 3; ++c) p[c] = &in.positions[3 * in.indices[3 * t + c]];
            float e1[3], e2[3];
            for (int k = 0; k < 3; ++k) e1[k] = p[1][k] - p[0][k], e2[k] = p[2][k] - p[0][k];
            float nx = e1[1] * e2[2] - e1[2] * e2[1], ny = e1[2] * e2[0] - e1[0] * e2[2], nz = e1[0] * e2[1] - e1[1] * e2[0];
            for (int c = 0; c < 3; ++c) {
                float* s = &normal_[3 * in.indices[3 * t + c]];
                s[0] += nx, s[1] += ny, s[2] += nz;
            }
        }
        double edge_sum = 0;
        for (auto& h : half) {
            const float* a = &in.positions[3 * (h.first >> 32)];
            const float* b = &in.positions[3 * (h.first & 0xFFFFFFFF)];
            edge_sum += std::sqrt(double(a[0] - b[0]) * (a[0] - b[0]) + double(a[1] - b[1]) * (a[1] - b[1]) + double(a[2] - b[2]) * (a[2] - b[2]));
        }
        amplitude_ = float(edge_sum / half.size() / n) * bump;
    }

    uint64_t point_count() const { return interior_first_ + in_.triangle_count() * interior(); }
    uint64_t triangle_count() const { return in_.triangle_count() * uint64_t(n_) * n_; }

    // emit(const float xyz[3]) for every point, in id order.
    template <class Emit>
    void for_each_point(Emit emit) const {
        for (size_t v = 0; v < in_.vertex_count(); ++v) emit(&in_.positions[3 * v]);
        uint64_t id = in_.vertex_count();
        for (uint32_t h : first_uses_) {
            const uint32_t a = in_.indices[h], b = in_.indices[h - h % 3 + (h + 1) % 3];
            const uint32_t c[3] = {std::min(a, b), std::max(a, b), std::min(a, b)};
            for (int s = 1; s < n_; ++s) {
                const float w[3] = {1.0f - float(s) / n_, float(s) / n_, 0};
                emit(displaced(w, c, id++).data());
            }
        }
        for (size_t t = 0; t < in_.triangle_count(); ++t)
            for (int j = 1; j < n_; ++j)
                for (int i = 1; i + j < n_; ++i) {
                    const float w[3] = {float(n_ - i - j) / n_, float(i) / n_, float(j) / n_};
                    emit(displaced(w, &in_.indices[3 * t], id++).data());
                }
    }

    // emit(const uint32_t abc[3]) for every triangle.
    template <class Emit>
    void for_each_triangle(Emit emit) const {
        const int n = n_;
        std::vector<uint32_t> grid(size_t(n + 1) * (n + 2) / 2);
        // Grid point (i, j), i + j ≤ n, sits at weights ((n−i−j)/n, i/n, j/n) of corners 0, 1, 2.
        auto at = [n](int i, int j) { return size_t(j) * (n + 1) - size_t(j) * (j - 1) / 2 + i; };
        for (size_t t = 0; t < in_.triangle_count(); ++t) {
            const uint32_t* c = &in_.indices[3 * t];
            auto edge_point = [&](int e, int s) {  // s steps from corner e towards corner e+1
                const uint64_t first = edge_first_[edge_of_[3 * t + e]];
                return uint32_t(c[e] < c[(e + 1) % 3] ? first + (s - 1) : first + (n - s - 1));
            };
            uint64_t inner = interior_first_ + t * interior();
            for (int j = 0; j <= n; ++j)
                for (int i = 0; i + j <= n; ++i) {
                    uint32_t id;
                    if (i == 0 && j == 0) id = c[0];
                    else if (i == n) id = c[1];
                    else if (j == n) id = c[2];
                    else if (j == 0) id = edge_point(0, i);
                    else if (i + j == n) id = edge_point(1, j);
                    else if (i == 0) id = edge_point(2, n - j);
                    else id = uint32_t(inner++);
                    grid[at(i, j)] = id;
                }
            for (int j = 0; j < n; ++j)
                for (int i = 0; i + j < n; ++i) {
                    const uint32_t lower[3] = {grid[at(i, j)], grid[at(i + 1, j)], grid[at(i, j + 1)]};
                    emit(lower);
                    if (i + j + 1 < n) {
                        const uint32_t upper[3] = {grid[at(i + 1, j)], grid[at(i + 1, j + 1)], grid[at(i, j + 1)]};
                        emit(upper);
                    }
                }
        }
    }

private:
    uint64_t interior() const { return uint64_t(n_ - 1) * (n_ - 2) / 2; }

    std::array<float, 3> displaced(const float w[3], const uint32_t c[3], uint64_t id) const {
        float p[3], nrm[3];
        for (int k = 0; k < 3; ++k) {
            p[k] = w[0] * in_.positions[3 * c[0] + k] + w[1] * in_.positions[3 * c[1] + k] + w[2] * in_.positions[3 * c[2] + k];
            nrm[k] = w[0] * normal_[3 * c[0] + k] + w[1] * normal_[3 * c[1] + k] + w[2] * normal_[3 * c[2] + k];
        }
        float len = std::sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        float d = len > 0 ? amplitude_ * (float(hash32(id) % 2001) / 1000.0f - 1.0f) / len : 0;
        return {p[0] + d * nrm[0], p[1] + d * nrm[1], p[2] + d * nrm[2]};
    }

    const strata::Mesh& in_;
    int n_;
    std::vector<uint32_t> edge_of_;     // per half-edge (3·triangle + corner): its edge
    std::vector<uint64_t> edge_first_;  // per edge: its first inner point
    std::vector<uint32_t> first_uses_;  // per edge, in order of first use: the half-edge that first uses it
    uint64_t interior_first_ = 0;       // the first triangle's first inner point
    std::vector<float> normal_;
    float amplitude_ = 0;
};

// Binary little-endian PLY, written through a temporary file renamed into place when complete.
void write_subdivision_ply(const std::string& path, const Subdivision& mesh) {
    if (mesh.point_count() > std::numeric_limits<uint32_t>::max())
        throw std::runtime_error(path + ": more points than 32-bit PLY indices hold");
    strata::AtomicOutputFile file(path);
    const std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by strata\nelement vertex " +
                               std::to_string(mesh.point_count()) +
                               "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                               std::to_string(mesh.triangle_count()) + "\nproperty list uchar uint vertex_indices\nend_header\n";
    file.write(header.data(), header.size());
    std::vector<char> buffer;
    auto put = [&](const void* bytes, size_t size) {
        buffer.insert(buffer.end(), static_cast<const char*>(bytes), static_cast<const char*>(bytes) + size);
        if (buffer.size() >= (size_t(8) << 20)) file.write(buffer.data(), buffer.size()), buffer.clear();
    };
    static_assert(std::endian::native == std::endian::little);
    mesh.for_each_point([&](const float* xyz) { put(xyz, 12); });
    mesh.for_each_triangle([&](const uint32_t* abc) {
        const uint8_t three = 3;
        put(&three, 1);
        put(abc, 12);
    });
    file.write(buffer.data(), buffer.size());
    file.commit();
}

struct ChildRun {
    double seconds = 0;
    double cpu_seconds = 0;  // user + system, all threads
    long peak_kb = 0;
    int status = -1;
};

ChildRun run_child(const std::vector<std::string>& args) {
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    auto start = Clock::now();
    pid_t pid = fork();
    if (pid == 0) {
        execv(argv[0], argv.data());
        _exit(127);
    }
    int status = 0;
    rusage usage{};
    wait4(pid, &status, 0, &usage);
    auto to_seconds = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
    return {seconds_since(start), to_seconds(usage.ru_utime) + to_seconds(usage.ru_stime), usage.ru_maxrss,
            WIFEXITED(status) ? WEXITSTATUS(status) : -1};
}

// --dem's FILE[:STRIDE]: the file, and the window of the whole grid at that stride.
std::pair<std::string, strata::test::DemWindow> dem_argument(const std::string& argument) {
    const size_t colon = argument.rfind(':');
    const std::string stride = colon == std::string::npos ? "" : argument.substr(colon + 1);
    if (stride.empty() || stride.find_first_not_of("0123456789") != std::string::npos) return {argument, {}};
    return {argument.substr(0, colon), {.stride = std::stoul(stride)}};
}

// The PLY the terrain is written to: a name per file, stride and unit, so a cached one is never another's.
std::string dem_ply_name(const std::string& argument, strata::test::ElevationUnit unit) {
    const auto [file, window] = dem_argument(argument);
    const char* unit_name = unit == strata::test::ElevationUnit::feet     ? "_feet"
                            : unit == strata::test::ElevationUnit::metres ? "_metres"
                                                                          : "";
    return std::filesystem::path(file).stem().string() + "_dem_s" + std::to_string(window.stride) + unit_name + ".ply";
}

}  // namespace

int main(int argc, char** argv) {
    std::string scan = std::string(STRATA_SOURCE_DIR) + "/data/bunny.off";
    std::string keep = std::filesystem::temp_directory_path() / "strata-bench";
    int splits = 16, runs = 3, threads = 0;
    bool with_meshopt = true, derive_only = false;
    std::string dem;  // FILE[:STRIDE], or empty: derive from the scan
    strata::test::ElevationUnit dem_unit = strata::test::ElevationUnit::from_units_attribute;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto value = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
        if (a == "--scan") scan = value();
        else if (a == "--splits") splits = std::stoi(value());
        else if (a == "--runs") runs = std::stoi(value());
        else if (a == "--threads") threads = std::stoi(value());
        else if (a == "--keep") keep = value();
        else if (a == "--no-meshopt") with_meshopt = false;
        else if (a == "--derive-only") derive_only = true;
        else if (a == "--dem") dem = value();
        else if (const std::string unit = a == "--dem-unit" ? value() : ""; unit == "feet" || unit == "metres")
            dem_unit = unit == "feet" ? strata::test::ElevationUnit::feet : strata::test::ElevationUnit::metres;
        else {
            std::fprintf(stderr, "usage: bench_build [--scan FILE | --dem FILE[:STRIDE] [--dem-unit feet|metres]] [--splits N] [--runs N] [--threads N] [--no-meshopt] [--keep DIR] [--derive-only]\n");
            return 2;
        }
    }
    std::filesystem::create_directories(keep);
    const std::string ply = dem.empty() ? keep + "/" + std::filesystem::path(scan).stem().string() + "_x" + std::to_string(splits * splits) + ".ply"
                                        : keep + "/" + dem_ply_name(dem, dem_unit);
    const std::string hlod = keep + "/bench.hlod";

    if (!dem.empty() && !std::filesystem::exists(ply)) {
        const auto [file, window] = dem_argument(dem);
        std::printf("making %s from the terrain %s (stride %zu)\n", ply.c_str(), file.c_str(), window.stride);
        strata::write_ply(ply, strata::test::read_dem_grid(file, window, {.variable = "", .unit = dem_unit}));
    } else if (!std::filesystem::exists(ply)) {
        std::printf("deriving %s from %s (each triangle split %d ways)\n", ply.c_str(), scan.c_str(), splits * splits);
        strata::Mesh base = strata::read_mesh(scan);
        write_subdivision_ply(ply, Subdivision(base, splits, 0.1f));
    }
    if (derive_only) return 0;
    const double ply_mb = std::filesystem::file_size(ply) / 1e6;

    // Binary PLY read, in process: median of three.
    std::vector<double> reads;
    strata::Mesh mesh;
    for (int r = 0; r < 3; ++r) {
        auto start = Clock::now();
        mesh = strata::read_mesh(ply);
        reads.push_back(seconds_since(start));
    }
    const double triangles = double(mesh.triangle_count());
    const double mesh_mb = mesh.memory_bytes() / 1e6;
    std::printf("mesh: %.2f M triangles, %.2f M vertices, binary PLY %.1f MB, in memory %.1f MB\n", triangles / 1e6,
                mesh.vertex_count() / 1e6, ply_mb, mesh_mb);
    const double read_s = median(reads);
    std::printf("read binary PLY:    %.3f s median of 3 = %.0f MB/s            (target ≥ 300 MB/s)\n", read_s, ply_mb / read_s);

    // meshopt_simplify to a quarter, once (it is the slow peer).
    double meshopt_s = 0;
    if (with_meshopt) {
        std::vector<unsigned int> out(mesh.indices.size());
        auto start = Clock::now();
        size_t kept = meshopt_simplify(out.data(), mesh.indices.data(), mesh.indices.size(), mesh.positions.data(),
                                       mesh.vertex_count(), 12, mesh.indices.size() / 4, 1e-2f);
        meshopt_s = seconds_since(start);
        std::printf("meshopt_simplify:   %.2f s to %.2f M triangles (one pass, on one thread)\n", meshopt_s, kept / 3 / 1e6);
    }
    mesh = strata::Mesh{};

    // The real executable, end to end.
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    std::vector<double> builds, build_cpus;
    long peak_kb = 0;
    for (int r = 0; r < runs; ++r) {
        ChildRun run = run_child({STRATA_EXECUTABLE, "build", ply, "-o", hlod, "-q", "--threads", std::to_string(threads)});
        if (run.status != 0) {
            std::fprintf(stderr, "bench_build: strata build failed (status %d)\n", run.status);
            return 1;
        }
        builds.push_back(run.seconds);
        build_cpus.push_back(run.cpu_seconds);
        peak_kb = std::max(peak_kb, run.peak_kb);
    }
    const double build_s = median(builds);
    const unsigned used = threads > 0 ? unsigned(threads) : cores;
    const double hlod_mb = std::filesystem::file_size(hlod) / 1e6;
    std::printf("strata build:       %.2f s median of %d on %u threads = %.2f M tri/s = %.2f M tri/s per core (target ≥ 1.5)\n",
                build_s, runs, used, triangles / build_s / 1e6, triangles / build_s / 1e6 / used);
    // CPU time does not grow when other programs share the cores; wall time does.
    const double cpu_s = median(build_cpus);
    std::printf("strata build CPU:   %.2f s median = %.2f M tri per CPU-second\n", cpu_s, triangles / cpu_s / 1e6);
    if (with_meshopt)
        std::printf("build / meshopt:    %.3f (build on %u threads, meshopt on one)     (target ≤ 0.25)\n", build_s / meshopt_s, used);
    std::printf("peak memory:        %.0f MB = %.2f × the mesh in memory             (target ≤ 2.5)\n", peak_kb / 1e3,
                peak_kb / 1e3 / mesh_mb);
    std::printf(".hlod size:         %.1f MB = %.2f × the binary PLY               (target ≤ 0.5)\n", hlod_mb, hlod_mb / ply_mb);
    std::filesystem::remove(hlod);
    return 0;
}
