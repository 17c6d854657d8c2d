#include "preprocess/input_scan.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace strata::build {
namespace {

void add_triangle(const float* p, InputScan& scan) {
    for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a) {
            const double x = p[3 * c + a];
            scan.low[size_t(a)] = std::min(scan.low[size_t(a)], x), scan.high[size_t(a)] = std::max(scan.high[size_t(a)], x);
            scan.longest_edge = std::max(scan.longest_edge, std::fabs(p[3 * c + a] - p[3 * ((c + 1) % 3) + a]));
        }
    if (scan.triangles % scan.stride == 0) {
        if (scan.sample.size() == InputScan::kMaxSample) {
            // Keep every other one: the sample stays every stride-th triangle, for twice the stride.
            for (size_t i = 0; i < scan.sample.size() / 2; ++i) scan.sample[i] = scan.sample[2 * i];
            scan.sample.resize(scan.sample.size() / 2);
            scan.stride *= 2;
        }
        if (scan.triangles % scan.stride == 0) scan.sample.push_back(barycenter(p, p + 3, p + 6));
    }
    ++scan.triangles;
}

}  // namespace

InputScan scan_inputs(const std::vector<std::unique_ptr<TriangleSource>>& sources, const Progress& progress) {
    InputScan scan;
    uint64_t total = 0, done = 0;
    for (const auto& source : sources) total += source->triangle_count();
    for (const auto& source : sources) {
        source->for_each(
            [&](const TriangleBatch& batch) {
                for (size_t t = 0; t < batch.triangle_count(); ++t) {
                    const float* p = &batch.positions[9 * t];
                    for (int k = 0; k < 9; ++k)
                        if (!std::isfinite(p[k]))
                            throw InputError(source->name() + ": a triangle has a vertex with a NaN or infinite coordinate");
                    for (int k = 0; k < 9; ++k) {
                        scan.corner_low[size_t(k % 3)] = std::min(scan.corner_low[size_t(k % 3)], double(p[k]));
                        scan.corner_high[size_t(k % 3)] = std::max(scan.corner_high[size_t(k % 3)], double(p[k]));
                    }
                    if (batch.degenerate(t)) ++scan.degenerate;
                    else add_triangle(p, scan);
                }
                done += batch.triangle_count();
                progress("scan", double(done), double(std::max(total, done)), "tri");
            },
            progress);
    }
    return scan;
}

Frame make_frame(const InputScan& scan, const std::string& source) {
    // The frame lives in the input's float space (partition, lattice and simplifier all measure float
    // positions against it); the true origin, the sources' origin + f.origin, is what the header records.
    Frame f{};
    for (int a = 0; a < 3; ++a) f.origin[a] = scan.low[size_t(a)];
    f.root_size = std::max({scan.high[0] - scan.low[0], scan.high[1] - scan.low[1], scan.high[2] - scan.low[2]});
    if (!(f.root_size > 0)) throw InputError(source + ": every vertex lies at one point");
    return f;
}

// Smallest L at which the typical triangle's cell (the load-weighted mean Σn²/Σn) holds at most `leaf`
// triangles. The scan keeps one triangle in k = stride: a cell of n triangles shows m ≈ n/k of them,
// and Σm² overstates Σn²/k² by about Σm (each sampled triangle meets itself), so the estimate is
// k·(Σm²/Σm − 1) + 1, not k·Σm²/Σm, which never falls below k: on 328 M triangles (k = 4096) that
// chose cells of 372 triangles.
uint32_t choose_levels(const InputScan& scan, const Frame& f, int leaf, uint32_t max_levels) {
    std::vector<CubeKey> keys;
    for (uint32_t level = 0; level < max_levels; ++level) {
        keys.clear();
        for (const auto& point : scan.sample) keys.push_back(cell_of(f, point, level));
        std::sort(keys.begin(), keys.end());
        double weighted = 0;
        for (size_t i = 0, j; i < keys.size(); i = j) {
            for (j = i; j < keys.size() && keys[j] == keys[i]; ++j) {
            }
            weighted += double(j - i) * double(j - i);
        }
        const double k = double(scan.stride);
        const double typical = k * (weighted / double(keys.size()) - 1) + 1;
        if (typical <= leaf) return level;
    }
    return max_levels;
}

}  // namespace strata::build
