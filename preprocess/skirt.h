// The skirt of an embedding (HYBRID.md §2): the ground between the zone Z (the level-(m − 1) cells its
// footprint touches) and the embedded mesh's boundary ring, triangulated at the raster's finest level in
// raster index space. Finest cells the ring does not touch keep the grid's two triangles; a cell the
// ring crosses is cut along it into polygons (the cell's corners outside the footprint, the ring's
// vertices inside the cell, and where the ring crosses the cell's sides), each ear-clipped.
//
// Cells are half-open ([c, c+1) × [r, r+1)): a ring vertex on a grid line belongs to the cell east and
// north of it (greater column, greater row), which settles every tie the same way for every cell.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "preprocess/footprint.h"

namespace strata {

struct SkirtVertex {
    enum class Kind : uint8_t {
        sample,    // a raster sample: column a, row b
        boundary,  // ring vertex a (Footprint::points[a])
        crossing,  // where ring edge a (from point a to a + 1) crosses a grid line, at t = num / den along it
    };
    Kind kind = Kind::sample;
    int64_t a = 0, b = 0;
    GridPoint at;              // where it lies (a crossing rounded to the lattice, on its grid line exactly)
    int64_t num = 0, den = 1;  // crossings: the exact parameter along the ring edge
};

struct Skirt {
    std::vector<SkirtVertex> vertices;
    std::vector<uint32_t> triangles;  // three vertices each, counter-clockwise in raster index space
    // Per ring edge, the crossing vertices along it in order from its first point: the skirt's own
    // boundary runs ring[e], crossings[e]…, ring[e + 1], which the seam to the mesh (whose edge has no
    // crossings) closes with zero-area triangles.
    std::vector<std::vector<uint32_t>> crossings;
    size_t cut_cells = 0;  // finest cells cut along the ring
};

// The skirt over the finest cells of the zone: `zone` the covers of the footprint at level m (its PC and
// CC cells are Z), the raster `columns` × `rows` samples. Throws InputError naming `what` where a cell
// cannot be cut (a ring inside one finest cell, or a ring so close to itself that a cell's polygon is not
// simple on the lattice).
Skirt build_skirt(const Footprint& footprint, const CellCovers& zone, int64_t columns, int64_t rows, const std::string& what);

}  // namespace strata
