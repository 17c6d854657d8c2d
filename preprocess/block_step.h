// One step of Algorithm 2 (000 §3.3.3) on one block: its level-l cubes are welded into one mesh,
// simplified with the points other blocks share locked, and cut into the level-(l−1) cubes they
// make (each surviving triangle goes to its own cube's parent); then the level-l cubes are encoded,
// each vertex naming its parent among the parent cube's vertices. Blocks are independent: run them
// in any order, on any thread, from memory or from disk.
#pragma once

#include <span>
#include <vector>

#include "preprocess/border_table.h"
#include "preprocess/build_cubes.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"

namespace strata::build {

struct EncodedCube {
    HlodNode node;        // node.error: F, the forward part of the bound (preprocess/error_bound.h)
    float coverage = 0;   // D: how far its triangles are from the parent level's surface
    std::vector<uint8_t> payload;
};

struct BlockOutput {
    std::vector<EncodedCube> encoded;   // the block's level-l cubes, in key order
    std::vector<CubeRecord> parents;    // the level-(l−1) cubes it made, in key order
    std::vector<BorderEntry> border;    // the points those parents list
};

// `cubes`: every level-l cube of one block, in key order; `border` lists level l's shared points.
BlockOutput simplify_block_cubes(std::span<const CubeRecord* const> cubes, uint32_t level, const BorderTable& border,
                                 const Frame& frame, const BuildSettings& settings, uint32_t flags);

// Level 0: the root cube, whose every vertex is its own parent.
EncodedCube encode_root(const CubeRecord& root, const BorderTable& border, const Frame& frame, uint32_t flags);

}  // namespace strata::build
