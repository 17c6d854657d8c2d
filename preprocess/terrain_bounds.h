// The error bound of a terrain's cubes (FORMAT.md §4.2 "error", the terms of preprocess/error_bound.h):
// the distances between one level of the grid pyramid and the next finer one, cell by cell.
//
// Both levels are maps of the same parameter plane, the DEM's (column, row), linear over every
// triangle. So a point of a coarse triangle and the point of a finer triangle at the same (column,
// row) are on the two surfaces, and over the part of the plane the two triangles share, the gap
// between them is linear: it peaks at a corner of that part (clipped in the plane). That bounds
// both ways at once, whatever the frame (a projected plane, or a tangent plane on which the grid
// is curved).
//
// Where holes (nodata) leave part of a coarse triangle without finer triangles under it, its points
// are within max |V − u| of the finer triangle that maps onto it (V = P(u) its corners: a point
// Σ b_i V_i has Σ b_i u_i on that triangle). A finer triangle with no coarse triangle over it collapses
// to an edge or a point of the coarse grid: when that is part of a coarse triangle, the same argument
// bounds it; otherwise (the coarse level has dropped a fragment of ground) by its distance to the
// nearest vertex a coarse triangle uses, searched within two coarse cells, or the model's diagonal.
#pragma once

#include <unordered_map>

#include "preprocess/terrain_pyramid.h"

namespace strata::terrain {

using CubeDistances = std::unordered_map<build::CubeKey, double>;

struct StepBound {
    CubeDistances forward;         // F of each coarse cube: its triangles' distance to the finer surface, F included
    CubeDistances finer_coverage;  // D of each finer cube: its triangles' distance to the coarse surface
};

// `finer_forward`: F of the finer level's cubes (empty at level L, where F = 0). `far`: the bound for
// a fragment with no coarse triangle nearby (the model's diagonal).
StepBound bound_step(const TerrainLevel& finer, const TerrainLevel& coarse, const CubeDistances& finer_forward, double far);

}  // namespace strata::terrain
