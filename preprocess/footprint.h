// Where an embedded mesh meets a terrain's grid (thesis 003 §2.1, hybrid terrain): the mesh's outer
// boundary (the TB ring) projected onto the grid, and each grid cell's cover at a level: not covered
// (NC, drawn by the grid), partly covered (PC, stitched to the ring) or completely covered (CC, dropped).
//
// Everything here is in the raster's index space: x = column, y = row (sample (c, r) at (c, r), rows
// as the raster stores them), where the samples every level keeps lie on multiples of its cell size
// (terrain_pyramid.h). Points sit on a fixed-point lattice of 2^-kGridPointBits cells, so every
// predicate (which side of a line, which cell) is exact: the classification and the stitch agree with
// each other bit for bit, on every machine.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "preprocess/mesh.h"

namespace strata {

inline constexpr int kGridPointBits = 20;  // a millionth of a cell: 1 µm on a 1 m DEM
inline constexpr int64_t kGridPointOne = int64_t(1) << kGridPointBits;

struct GridPoint {
    int64_t x = 0, y = 0;
    bool operator==(const GridPoint&) const = default;
};

// Exact arithmetic on lattice coordinates: products of two coordinates or differences fit 128 bits.
using WideInt = __int128;
inline WideInt floor_div(WideInt n, WideInt d) {
    WideInt q = n / d;
    if (n % d != 0 && ((n < 0) != (d < 0))) --q;
    return q;
}
inline WideInt ceil_div(WideInt n, WideInt d) { return -floor_div(-n, d); }

// The point nearest `p` (raster index space) on the lattice; std::runtime_error beyond ±2^40 cells.
GridPoint to_grid_point(glm::dvec2 p);

// > 0 when c lies left of a→b (counter-clockwise in (x, y)), < 0 right of it, 0 on the line; exact.
int orientation(GridPoint a, GridPoint b, GridPoint c);

// The boundary loops of a mesh, vertices welded by exact position (seam copies of a vertex are one
// vertex; each loop names one copy), each loop in the direction its triangles run along it. Throws
// InputError naming `what` where a boundary vertex starts two boundary edges (two loops touching in a
// point: which way the loop goes is ambiguous).
std::vector<std::vector<uint32_t>> boundary_loops(const Mesh& mesh, std::string_view what);

struct Footprint {
    std::vector<uint32_t> ring;     // the outer boundary loop's mesh vertices (TB), one turn, no repeat
    std::vector<GridPoint> points;  // where each lies on the grid, in the same order
    size_t inner_loops = 0;         // the mesh's holes (loops inside the outer one): not embedded
    // Orientation: the ring runs counter-clockwise in raster index space (positive shoelace area over
    // (column, row)), which is clockwise seen from above for the usual north-up raster (thesis 003's
    // order, l.745), whatever way the mesh's triangles run.
};

// The footprint of `mesh` on a grid, `to_grid` taking a mesh vertex's true position (origin +
// position, in double) to raster index space. The outer loop is the one enclosing the largest area.
// Throws InputError naming `what` for a mesh without an open boundary (a closed surface: its ground
// footprint is not extracted yet), a ring that crosses or touches itself or encloses no area, and a
// ring reaching outside [0, columns−1] × [0, rows−1].
Footprint make_footprint(const Mesh& mesh, const std::function<glm::dvec2(const glm::dvec3&)>& to_grid, int64_t columns,
                         int64_t rows, std::string_view what);

enum class CellCover : uint8_t { none, partly, whole };  // NC, PC, CC

// The cover of the cells of one level's grid around a ring (a footprint's points): cells `size` raster steps wide (2^(L−l)
// at level l; the last column and row of cells end at the raster's last sample), those in
// [first_x, first_x + width) × [first_y, first_y + height) listed row by row; every cell outside is NC.
// A cell is PC when its closed square meets the ring (a ring vertex on a grid line or corner makes
// every cell that line or corner bounds PC), CC when it lies wholly inside the ring, else NC.
struct CellCovers {
    int64_t size = 1;
    int64_t first_x = 0, first_y = 0, width = 0, height = 0;
    std::vector<CellCover> cover;

    CellCover at(int64_t x, int64_t y) const {
        if (x < first_x || y < first_y || x >= first_x + width || y >= first_y + height) return CellCover::none;
        return cover[size_t((y - first_y) * width + (x - first_x))];
    }
};
CellCovers classify_cells(const std::vector<GridPoint>& ring, int64_t cell_size, int64_t columns, int64_t rows);

// Calls `visit(x, y)` for every finest cell of the zone `covers` marks (PC or CC), row by row within
// each of its cells, those past the raster's last sample left out.
void for_each_finest_cell(const CellCovers& covers, int64_t columns, int64_t rows, const std::function<void(int64_t x, int64_t y)>& visit);

// The corners of the box around `points` (not empty).
std::pair<GridPoint, GridPoint> bounds(const std::vector<GridPoint>& points);

// Whether `p`, on no edge of the closed `ring`, lies inside it (crossing number, exact).
bool ring_contains(const std::vector<GridPoint>& ring, GridPoint p);

// Throws InputError naming `what` when the closed ring crosses or touches itself: two edges but
// neighbours meeting, neighbours folding back on each other, or a point repeated.
void check_ring_simple(const std::vector<GridPoint>& ring, std::string_view what);

// Calls `visit(x, y)` for every cell (of `cell_size` raster steps, uniform) whose closed square meets the
// closed segment a–b: a cell once per segment. (The classification's PC test; the ring's self-crossing
// check buckets edges with it.)
void cells_touched(GridPoint a, GridPoint b, int64_t cell_size, const std::function<void(int64_t x, int64_t y)>& visit);
// The same for squares of `side` lattice steps (the grid of any bucketing, not only of cells).
void squares_touched(GridPoint a, GridPoint b, int64_t side, const std::function<void(int64_t x, int64_t y)>& visit);

}  // namespace strata
