// The levels of a terrain built straight from a DEM (issue 17): a regular grid pyramid, no QEM.
//
// Level L holds every sample. Along each axis, a coarser level keeps every other sample of the
// level below it and that level's last one, so every level is a regular grid (its last row and
// column may be narrower), nested in the one below. A cell's two triangles share the diagonal
// from its minimum corner (smallest column and row) to its maximum corner, on every level.
//
// The parent of a vertex is, per axis, the largest kept index of the coarser level not above its
// own (the last index is its own parent). Under that map every coarse cell has exactly one finer
// cell mapping onto it whole, the one at its maximum corner: its two triangles become the coarse
// cell's two, with the same diagonal, and every other finer triangle collapses to an edge or a
// point. So a coarse triangle exists exactly when that finer triangle does (holes at nodata grow
// by at most a cell per level and never cover valid ground), it goes to the parent of that
// triangle's cube (P(T(C)) is the parent's part from C, as `strata verify` checks), and a vertex
// lies at most one finer step from its parent on each axis.
//
// A vertex of a coarser level whose sample is nodata, but which some finer vertex needs as its
// parent, takes the position of the first such finer vertex in row order: it stays within one
// finer step of all of them.
#pragma once

#include <cstdint>
#include <vector>

#include "preprocess/build_cubes.h"

namespace strata::terrain {

inline constexpr build::CubeKey kNoTriangle = ~build::CubeKey(0);

enum VertexFlags : uint8_t {
    kSampleValid = 1,  // the DEM has a value here (its position is the sample's)
    kUsed = 2,         // a triangle of this level uses it
    kNeeded = 4,       // used, or the parent of a vertex the finer level needs: it has a position
};

// One axis of a level over a window of the raster (or all of it): the DEM sample indices the level keeps
// there, increasing, and whether the last of them is the raster's last sample. A window starts on a
// sample every level keeps.
struct Axis {
    std::vector<uint64_t> index;
    bool ends_raster = true;

    size_t size() const { return index.size(); }
    uint64_t operator[](size_t position) const { return index[position]; }
    // The coarser level's axis: every other index from the first, and the raster's last.
    Axis coarser() const;
    // Where the parent of this axis's `position`-th index lies in the coarser axis.
    size_t parent(size_t position) const {
        return ends_raster && position + 1 == size() ? (position + 1) / 2 : position / 2;
    }
    // Where the coarser axis's `position`-th index lies in this one.
    size_t finer(size_t position, const Axis& coarse) const {
        return ends_raster && position + 1 == coarse.size() ? size() - 1 : 2 * position;
    }
};

struct TerrainLevel {
    uint32_t level = 0;
    Axis columns, rows;  // the DEM sample indices this level keeps
    // Rows run south in model space (y north) unless the raster stores them south-up; triangles
    // are counter-clockwise seen from above either way.
    bool rows_run_north = false;
    std::vector<double> position;   // 3 per vertex, row-major; model coordinates where kNeeded or kSampleValid
    std::vector<uint8_t> flags;     // VertexFlags per vertex
    // 2 per cell, row-major over (width − 1) × (height − 1): the cube of triangle t of the cell, or
    // kNoTriangle. Triangle 0 has corners min, (min column, max row), max; triangle 1 has min, max,
    // (max column, min row).
    std::vector<build::CubeKey> cube;

    size_t width() const { return columns.size(); }
    size_t height() const { return rows.size(); }
    uint64_t vertex(size_t column, size_t row) const { return uint64_t(row) * width() + column; }
    uint64_t cell(size_t column, size_t row) const { return uint64_t(row) * (width() - 1) + column; }
    const double* at(uint64_t vertex) const { return &position[3 * vertex]; }
    // The three vertices of triangle t of the cell, counter-clockwise seen from above.
    std::array<uint64_t, 3> corners(size_t column, size_t row, int t) const;
    uint64_t triangle_count() const;
};

// The cell of `finer` that maps whole onto cell (column, row) of `coarse`, the next coarser level: the
// one at its maximum corner (see the top of this file). Its triangle t makes the coarse cell's.
uint64_t preimage_cell(const TerrainLevel& finer, const TerrainLevel& coarse, size_t column, size_t row);

// The next coarser level of `finer` (see the top of this file).
TerrainLevel coarser_level(const TerrainLevel& finer);

// Marks every vertex a triangle uses kUsed | kNeeded (the finest level, once `cube` is filled).
void mark_used(TerrainLevel& level);

// Area-weighted vertex normals over the level's triangles, octahedral (2 per vertex; up where no
// triangle uses the vertex): the same for every cube that shares a vertex. Summed on the level's
// lattice exactly as a payload predicts a normal from its cube's triangles (FORMAT.md §7), so only a
// cube's border vertices, whose triangles it does not all hold, cost a residual.
std::vector<int16_t> lattice_normals(const TerrainLevel& level, const build::Frame& f);

// Moves every vertex's height to the nearest `origin_z + k·quantum` (its level's height lattice,
// preprocess/terrain_build.h).
void snap_heights(TerrainLevel& level, double origin_z, double quantum);

}  // namespace strata::terrain
