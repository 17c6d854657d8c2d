// The model's open boundary, found out of core for BuildSettings::lock_boundary: the edges an odd number
// of level L's triangles use, their ends welded by exact position (seam copies of a vertex are one point).
//
// A block sees only its own triangles, and an edge near its border may be used by a neighbour's too. So
// each level-L job cancels the edges its block uses twice (keeps those it uses an odd number of times)
// and lists what is left in its cube file: the boundary inside the block, and the frontier its border
// cuts (edges whose other triangle lies in a neighbour). Every block that uses an end of an edge touches
// every block that uses the edge (a vertex lies within σ0·s_L < s_L/2 of its cube, border_table.h), so
// the first simplifying job of block B, which reads B's and its 26 neighbours' cube files anyway (for
// their border listings), cancels their lists against each other, and what stays odd is exactly the
// boundary at B's points. Cost: a level-L job sorts its block's edges (24 bytes each, three a
// triangle, beside the triangles it already holds); each list, on disk and in a job's memory, is the
// block's boundary plus its frontier (about the square root of its triangles a side), never the model.
// No pass over the whole model and no stage of its own: jobs stay independent, and the lists depend on
// the blocks alone, so the result is the same at any thread count, in any process, resumed or not.
//
// Parity, rather than "used by one triangle": the same on a surface, and what collapses keep. Collapsing
// u into w turns each triangle on an edge u–x into one on w–x, unless it also holds w: then it vanishes,
// and w–x loses that use. So w–x's count changes by count(u–x) − 2·(triangles on u, w and x), and no
// other edge's but u's own: even, when every edge of u is used an even number of times. With every end
// of an odd edge locked, every level has exactly the finest level's odd edges (what `strata verify`
// checks). An edge that three sheets share is one of them, and is locked too.
#pragma once

#include <compare>
#include <vector>

#include "preprocess/border_table.h"
#include "preprocess/build_cubes.h"

namespace strata::build {

// An edge by its ends' positions, the lesser first.
struct OpenEdge {
    PositionBits a, b;
    auto operator<=>(const OpenEdge&) const = default;
};

// The edges that an odd number of `cubes`' triangles use (one level-L block's cubes), in order.
std::vector<OpenEdge> odd_edges(const std::vector<CubeRecord>& cubes);

// Sets the boundary flags of `cubes` (one level-L block's): the ends of the edges an odd number of
// triangles use in all, from `listed`, the odd_edges of the block and of its neighbours. A cube none
// of whose vertices is on the boundary keeps no flags.
void mark_boundary(std::vector<CubeRecord>& cubes, std::vector<OpenEdge> listed);

}  // namespace strata::build
