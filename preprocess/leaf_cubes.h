// Level L from the spilled triangles (000 §3.3.2, phase 2): block by block, every triangle goes to the
// level-L cell of its barycenter (never cut), and each cube welds its corners into its own vertices
// (corners equal in position and every kept attribute are one vertex, as weld() has it), puts them in
// payload order and lists its border points.
#pragma once

#include <vector>

#include "preprocess/border_table.h"
#include "preprocess/build_cubes.h"
#include "preprocess/triangle_spill.h"

namespace strata::build {

struct LeafBlock {
    std::vector<CubeRecord> cubes;   // in key order
    std::vector<BorderEntry> border;  // the points they list
};

// One level-L block's cubes from its run of spilled triangles (`records`, in input order).
LeafBlock leaf_block(const std::vector<uint8_t>& records, const CornerLayout& layout, const Frame& frame);

}  // namespace strata::build
