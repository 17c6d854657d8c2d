#include "preprocess/error_bound.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "preprocess/hlod_format.h"
#include "preprocess/surface_distance.h"

namespace strata::build {
namespace {

// Cubes' triangles as one surface, each triangle knowing its cube.
struct FlatSurface {
    std::vector<float> positions;
    std::vector<uint32_t> triangles, groups;

    void add(const CubeRecord& cube, uint32_t group) {
        const uint32_t first = uint32_t(positions.size() / 3);
        positions.insert(positions.end(), cube.positions.begin(), cube.positions.end());
        for (uint32_t v : cube.triangles) triangles.push_back(first + v);
        groups.insert(groups.end(), cube.triangle_count(), group);
    }
    SurfaceView view() const { return {positions, triangles}; }
};

}  // namespace

// Half a lattice step per axis, plus the float arithmetic of the decode (a step rounded to float, q·h
// rounded, q itself past 2^24), each under 2^-24 of a coordinate, coordinates under 1.5·L_c.
double lattice_rounding(double root_size, double cube_size) {
    const double step = cube_size / double(1 << kLatticeBits);
    return std::sqrt(3.0) * (0.5 * step + std::ldexp(root_size, -21));
}

float round_up(double x) {
    const float f = float(x);
    return double(f) >= x ? f : std::nextafter(f, INFINITY);
}

StepBounds bound_step(std::span<const CubeRecord* const> cubes, std::span<const CubeRecord> parents, double parent_size) {
    FlatSurface level, coarser;
    for (uint32_t c = 0; c < cubes.size(); ++c) level.add(*cubes[c], c);
    for (uint32_t p = 0; p < parents.size(); ++p) coarser.add(parents[p], p);
    std::vector<float> carried(level.groups.size());
    for (size_t t = 0; t < carried.size(); ++t) carried[t] = cubes[level.groups[t]]->error;

    const double tolerance = kBoundTolerance * parent_size;
    const TriangleTree fine(level.view(), carried), coarse(coarser.view(), {});
    const std::vector<DistanceBound> forward =
        directed_distance(coarser.view(), coarser.groups, uint32_t(parents.size()), fine, tolerance);
    const std::vector<DistanceBound> coverage =
        directed_distance(level.view(), level.groups, uint32_t(cubes.size()), coarse, tolerance);
    StepBounds out;
    for (const DistanceBound& b : forward) out.parent_forward.push_back(round_up(b.upper));
    for (const DistanceBound& b : coverage) out.cube_coverage.push_back(round_up(b.upper));
    return out;
}

std::vector<float> final_bounds(std::span<const CubeErrors> cubes, const Frame& f, bool locked_boundary) {
    using Key = std::array<uint32_t, 4>;
    std::map<Key, uint32_t> index;
    std::vector<std::vector<uint32_t>> by_level(f.max_level + 1);
    for (uint32_t c = 0; c < cubes.size(); ++c) {
        index[{cubes[c].level, cubes[c].i, cubes[c].j, cubes[c].k}] = c;
        by_level[cubes[c].level].push_back(c);
    }
    std::vector<double> coverage_error(cubes.size(), 0.0);  // E
    std::vector<float> out(cubes.size(), 0.0f);
    for (uint32_t l = f.max_level + 1; l-- > 0;) {
        const double size = f.cube_size(l), rounding = lattice_rounding(f.root_size, locked_boundary ? f.root_size : size);
        double level_worst = 0;  // the largest D of the level: the reach of a cube whose E is too large
        for (uint32_t c : by_level[l]) level_worst = std::max(level_worst, double(cubes[c].coverage));
        for (uint32_t c : by_level[l]) {
            const CubeErrors& cube = cubes[c];
            out[c] = std::max(out[c], round_up(std::max(double(cube.forward), coverage_error[c]) + rounding));
            if (l == 0) continue;
            // The level-l surface within E(c) of S_c: S_c lies within σ0·s_L of c's cell, a level-l
            // triangle within σ0·s_l of its cube's, so past the 26 neighbours only if E(c) is that big.
            double reach = cube.coverage;
            if (coverage_error[c] >= (1 - f.sigma0) * size - f.sigma0 * f.cube_size(f.max_level)) {
                reach = level_worst;
            } else if (coverage_error[c] > 0) {
                for (int dk = -1; dk <= 1; ++dk)
                    for (int dj = -1; dj <= 1; ++dj)
                        for (int di = -1; di <= 1; ++di) {
                            auto it = index.find({l, cube.i + di, cube.j + dj, cube.k + dk});
                            if (it != index.end()) reach = std::max(reach, double(cubes[it->second].coverage));
                        }
            }
            auto parent = index.find({l - 1, cube.i / 2, cube.j / 2, cube.k / 2});
            if (parent == index.end()) continue;
            coverage_error[parent->second] = std::max(coverage_error[parent->second], coverage_error[c] + reach);
            out[parent->second] = std::max(out[parent->second], out[c]);
        }
    }
    return out;
}

}  // namespace strata::build
