// Level L from the spilled triangles (000 §3.3.2, phase 2): block by block, every triangle goes to the
// level-L cell of its barycenter (never cut), and each cube welds its corners into its own vertices
// (corners equal in position and every kept attribute are one vertex, as weld() has it), puts them in
// payload order and lists its border points.
#pragma once

#include "preprocess/border_table.h"
#include "preprocess/build_cubes.h"
#include "preprocess/cube_store.h"
#include "preprocess/progress.h"
#include "preprocess/triangle_spill.h"

namespace strata::build {

// Puts level L's cubes in `store`, and the points they list in `listed`, keyed by block. Gives the
// spill's disk back block by block.
void leaf_cubes(RunSpill& spill, const CornerLayout& layout, const Frame& frame, unsigned threads, CubeStore& store,
                RunSpill& listed, const Progress& progress);

}  // namespace strata::build
