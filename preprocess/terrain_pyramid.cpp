#include "preprocess/terrain_pyramid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "preprocess/hlod_format.h"

namespace strata::terrain {

Axis Axis::coarser() const {
    if (index.empty()) throw std::logic_error("Axis::coarser: an empty axis");
    Axis coarse;
    coarse.ends_raster = ends_raster;
    coarse.index.resize(parent(size() - 1) + 1);
    for (size_t p = 0; p < coarse.size(); ++p) coarse.index[p] = index[finer(p, coarse)];
    return coarse;
}

std::array<uint64_t, 3> TerrainLevel::corners(size_t column, size_t row, int t) const {
    const uint64_t min = vertex(column, row), max = vertex(column + 1, row + 1);
    const uint64_t side = t == 0 ? vertex(column, row + 1) : vertex(column + 1, row);
    // With rows running south, (min, min-column-max-row, max) turns counter-clockwise seen from above.
    const bool turn = (t == 0) != rows_run_north;
    return turn ? std::array{min, side, max} : std::array{min, max, side};
}

uint64_t TerrainLevel::triangle_count() const {
    uint64_t count = 0;
    for (build::CubeKey key : cube) count += key != kNoTriangle;
    return count;
}

uint64_t preimage_cell(const TerrainLevel& finer, const TerrainLevel& coarse, size_t column, size_t row) {
    return finer.cell(finer.columns.finer(column + 1, coarse.columns) - 1, finer.rows.finer(row + 1, coarse.rows) - 1);
}

namespace {

// Vertices: each coarse vertex is the finer vertex at the same sample; a needed coarse vertex whose
// sample is nodata takes the first needed finer vertex (row order) that maps onto it.
void coarse_vertices(const TerrainLevel& finer, TerrainLevel& coarse) {
    const size_t w = coarse.width(), h = coarse.height();
    coarse.position.assign(3 * w * h, 0.0);
    coarse.flags.assign(w * h, 0);
    for (size_t r = 0; r < h; ++r)
        for (size_t c = 0; c < w; ++c) {
            const uint64_t f = finer.vertex(finer.columns.finer(c, coarse.columns), finer.rows.finer(r, coarse.rows));
            const uint64_t v = coarse.vertex(c, r);
            if (!(finer.flags[f] & kSampleValid)) continue;
            coarse.flags[v] = kSampleValid;
            for (int a = 0; a < 3; ++a) coarse.position[3 * v + a] = finer.position[3 * f + a];
        }
    for (size_t r = 0; r < finer.height(); ++r)
        for (size_t c = 0; c < finer.width(); ++c) {
            const uint64_t f = finer.vertex(c, r);
            if (!(finer.flags[f] & kNeeded)) continue;
            const uint64_t v = coarse.vertex(finer.columns.parent(c), finer.rows.parent(r));
            if (!(coarse.flags[v] & (kSampleValid | kNeeded)))
                for (int a = 0; a < 3; ++a) coarse.position[3 * v + a] = finer.position[3 * f + a];
            coarse.flags[v] |= kNeeded;
        }
}

// Triangles: a coarse cell's triangle t exists when triangle t of the finer cell at its maximum
// corner does, in that triangle's cube's parent.
void coarse_triangles(const TerrainLevel& finer, TerrainLevel& coarse) {
    const size_t w = coarse.width(), h = coarse.height();
    coarse.cube.assign(2 * (w - 1) * (h - 1), kNoTriangle);
    for (size_t r = 0; r + 1 < h; ++r)
        for (size_t c = 0; c + 1 < w; ++c) {
            const uint64_t preimage = preimage_cell(finer, coarse, c, r);
            for (int t = 0; t < 2; ++t) {
                const build::CubeKey key = finer.cube[2 * preimage + t];
                if (key == kNoTriangle) continue;
                coarse.cube[2 * coarse.cell(c, r) + t] = build::parent_key(key);
                for (uint64_t v : coarse.corners(c, r, t)) {
                    if (!(coarse.flags[v] & kNeeded)) throw std::logic_error("terrain pyramid: a triangle uses an unneeded vertex");
                    coarse.flags[v] |= kUsed;
                }
            }
        }
}

}  // namespace

TerrainLevel coarser_level(const TerrainLevel& finer) {
    if (finer.level == 0) throw std::logic_error("coarser_level: level 0 is the coarsest");
    TerrainLevel coarse;
    coarse.level = finer.level - 1;
    coarse.rows_run_north = finer.rows_run_north;
    coarse.columns = finer.columns.coarser();
    coarse.rows = finer.rows.coarser();
    coarse_vertices(finer, coarse);
    coarse_triangles(finer, coarse);
    return coarse;
}

void mark_used(TerrainLevel& level) {
    for (size_t r = 0; r + 1 < level.height(); ++r)
        for (size_t c = 0; c + 1 < level.width(); ++c)
            for (int t = 0; t < 2; ++t)
                if (level.cube[2 * level.cell(c, r) + t] != kNoTriangle)
                    for (uint64_t v : level.corners(c, r, t)) level.flags[v] |= kUsed | kNeeded;
}

std::vector<int16_t> lattice_normals(const TerrainLevel& level, const build::Frame& f) {
    // Each vertex on the level's lattice, in global steps: within a cube, differences of these are the
    // differences of the payload's stored values, so the sums below are what the payload predicts.
    std::vector<int64_t> q(level.position.size());
    for (size_t v = 0; v < level.flags.size(); ++v)
        if (level.flags[v] & kNeeded)
            for (int a = 0; a < 3; ++a) q[3 * v + size_t(a)] = build::lattice_offset(f, level.position[3 * v + size_t(a)], a, level.level, 0);
    std::vector<std::array<uint64_t, 3>> sums(level.flags.size(), {0, 0, 0});
    for (size_t r = 0; r + 1 < level.height(); ++r)
        for (size_t c = 0; c + 1 < level.width(); ++c)
            for (int t = 0; t < 2; ++t) {
                if (level.cube[2 * level.cell(c, r) + t] == kNoTriangle) continue;
                const std::array<uint64_t, 3> v = level.corners(c, r, t);
                const int64_t *a = &q[3 * v[0]], *b = &q[3 * v[1]], *d = &q[3 * v[2]];
                const int64_t e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, g[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
                const uint64_t n[3] = {uint64_t(e[1] * g[2] - e[2] * g[1]), uint64_t(e[2] * g[0] - e[0] * g[2]),
                                       uint64_t(e[0] * g[1] - e[1] * g[0])};
                for (uint64_t corner : v)
                    for (int x = 0; x < 3; ++x) sums[corner][size_t(x)] += n[x];
            }
    std::vector<int16_t> normals(2 * sums.size());
    for (size_t v = 0; v < sums.size(); ++v) {
        const std::array<int16_t, 2> n = lattice_normal(sums[v]);
        normals[2 * v] = n[0], normals[2 * v + 1] = n[1];
    }
    return normals;
}

void snap_heights(TerrainLevel& level, double origin_z, double quantum) {
    for (size_t v = 0; v < level.flags.size(); ++v) {
        if (!(level.flags[v] & (kNeeded | kSampleValid))) continue;
        double& z = level.position[3 * v + 2];
        z = origin_z + std::round((z - origin_z) / quantum) * quantum;
    }
}

}  // namespace strata::terrain
