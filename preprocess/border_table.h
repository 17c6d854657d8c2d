// Which points of a level more than one block uses, and their normals, without holding the level:
// each cube lists the points on its open edges near its block's border (an edge open in the cube is
// where its surface continues in another cube), with its share of their area-weighted normal. A
// point that blocks share is listed by a cube of each (a surface split by a border has open edges on
// both sides), so a block locks the points another block lists, and takes their normals from the sum
// of every listing's share: the same float sums in every block, in cube order, at any thread count.
// The one exception is a pinch: two surfaces touching at a single vertex, one of them closed around it
// inside its block. That block lists nothing there: it locks the vertex (the other block lists it), but
// the other block, seeing no listing but its own, may move it, and the surfaces part at that point
// (never along an edge: an edge is open on both of its sides).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "preprocess/build_cubes.h"
#include "preprocess/index_map.h"

namespace strata::build {

// A position's bits with −0 made +0: the identity of a point.
using PositionBits = std::array<uint32_t, 3>;
PositionBits position_bits(const float* position);
uint64_t hash_position(const PositionBits& bits);

// point_of[v]: one id per distinct position among `count` positions; returns how many there are.
uint32_t weld_positions(const float* positions, uint32_t count, std::vector<uint32_t>& point_of);

struct BorderEntry {
    PositionBits position;
    CubeKey block;  // the block (of the cube's level) of the cube listing it
    CubeKey cube;
    std::array<float, 3> normal_sum;  // the cube's triangles' area-weighted normals at the point
};

// The entries of one level-l cube: points on its open edges within reach of another block (a
// vertex lies within σ0·s_l of its own cube's cell, so only those near the border can be shared).
void list_border_points(const CubeRecord& cube, const Frame& frame, uint32_t level, std::vector<BorderEntry>& out);

class BorderTable {
public:
    BorderTable() = default;
    explicit BorderTable(std::vector<BorderEntry> entries);

    struct Point {
        CubeKey first_block;
        bool several_blocks;
        std::array<float, 3> normal_sum;  // over every listing, in cube order
        // A block may not move a point that another block also uses.
        bool locked_for(CubeKey block) const { return several_blocks || first_block != block; }
    };
    const Point* find(const PositionBits& position) const;
    size_t size() const { return points_.size(); }
    size_t memory_bytes() const {
        return points_.capacity() * sizeof(Point) + positions_.capacity() * sizeof(PositionBits) + index_.memory_bytes();
    }

private:
    std::vector<PositionBits> positions_;
    std::vector<Point> points_;
    // Every block looks up each of its points: hashed, one probe or two, where a binary search over
    // the level's border took some twenty cache misses.
    IndexMap index_{0};
};

// The table a level-`level` block looks its points up in: of `candidates` (listings of that level), those
// within the block's reach. A block's table needs every listing of a point it uses, and those are
// listed near it: a vertex lies within σ0·s_l (σ0 < 1/2) of its cube, so two cubes sharing a point
// touch, and so do their blocks. So the listings of a block and its 26 neighbours, or of the jobs that
// made the cubes within one cube of the block (hlod_builder.cpp), give the same table as the level's
// whole listing.
BorderTable block_border_table(const std::vector<BorderEntry>& candidates, CubeKey block, const Frame& f, uint32_t level);

}  // namespace strata::build
