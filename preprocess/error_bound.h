// The cubes' error bound (FORMAT.md §4.2 "error"; DESIGN.md §8): for a cube c of level l, a number
// e(c) in model units such that
//   forward:  every point of c's triangles lies within e(c) of the full-resolution surface S, and
//   coverage: every point of S_c (the full-resolution triangles under c's cell) lies within e(c) of
//             level l's surface,
// both as drawn from the lattice (quantization included), without the morph toward the parent.
//
// Built level by level with the triangle inequality, from conservative distances between one level
// and the next (preprocess/surface_distance.h):
//   F(c) = sup over c's triangles of min over level l+1's surface y of |x − y| + F(cube of y),
//          F = 0 at level L, whose triangles are the input's;
//   D(c) = sup over c's triangles of the distance to level l−1's surface (its parents' block);
//   E(p) = max over children c of E(c) + max D over the cubes whose triangles can lie within E(c)
//          of S_c (c alone while E(c) = 0, else its 26 neighbours), E = 0 at level L;
//   e(c) = max(F(c), E(c)) + the lattice's rounding, raised to its children's largest e.
// F and D come from each block's step (one block's cubes and its parents); E needs the neighbours'
// D, which other blocks computed, so it is chained in the assembly, over the node table alone.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "preprocess/build_cubes.h"

namespace strata::build {

// How close to the true distance each step's bound is computed, relative to the parent level's cube
// size: the bound is at most this much above the distance it bounds.
inline constexpr double kBoundTolerance = 1.0 / 1024;

struct StepBounds {
    std::vector<float> parent_forward;  // F per parent, in the parents' order
    std::vector<float> cube_coverage;   // D per level-l cube, in the cubes' order
};

// The step from one block's level-l cubes (whose CubeRecord::error is F) to the parents made of them.
StepBounds bound_step(std::span<const CubeRecord* const> cubes, std::span<const CubeRecord> parents, double parent_size);

struct CubeErrors {
    uint32_t level, i, j, k;
    float forward;   // F
    float coverage;  // D (0 at the root)
};

// e(c) per cube, in the input's order, for a model of frame `f`. `locked_boundary`: the model's boundary
// vertices lie on level 0's lattice at every level (BuildSettings::lock_boundary), so a vertex may be
// drawn up to h_0/2 from its position, not h_l/2: every cube's rounding is level 0's (a cube's coverage
// reaches its neighbours' triangles, which may hold such vertices where it holds none).
std::vector<float> final_bounds(std::span<const CubeErrors> cubes, const Frame& f, bool locked_boundary = false);

// How far a vertex of a cube of size `cube_size` may be drawn from the position it encodes (the
// lattice's rounding and the decode's float arithmetic), in a model of root size `root_size`: every
// bound includes it.
double lattice_rounding(double root_size, double cube_size);

// The smallest float not below x (a bound must not round down).
float round_up(double x);

}  // namespace strata::build
