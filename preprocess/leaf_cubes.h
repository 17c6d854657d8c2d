// Level L from the input mesh (000 §3.2.3): every triangle in the level-L cell of its barycenter,
// never cut; each cube gets its own copy of the vertices it uses, in payload order, and lists its
// border points.
#pragma once

#include <vector>

#include "preprocess/border_table.h"
#include "preprocess/build_cubes.h"
#include "preprocess/cube_store.h"
#include "preprocess/mesh.h"

namespace strata::build {

// Puts level L's cubes in `store` and returns the points they list. Releases the mesh's arrays.
std::vector<BorderEntry> leaf_cubes(Mesh& mesh, const Frame& frame, unsigned threads, CubeStore& store);

}  // namespace strata::build
