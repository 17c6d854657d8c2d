// Level L from the input mesh (000 §3.2.3): every triangle in the level-L cell of its barycenter,
// never cut; each cube gets its own copy of the vertices it uses, in payload order, and lists its
// border points.
#pragma once

#include <vector>

#include "preprocess/border_table.h"
#include "preprocess/build_cubes.h"
#include "preprocess/mesh.h"

namespace strata::build {

struct CubeLevel {
    std::vector<CubeRecord> cubes;    // in key order
    std::vector<BorderEntry> border;  // every cube's listed points (any order)
};

// Releases the mesh's arrays as it goes.
CubeLevel leaf_cubes(Mesh& mesh, const Frame& frame, unsigned threads);

}  // namespace strata::build
