// `strata verify`: checks every invariant of DESIGN.md §2 on a .hlod file and names the first violation.
#pragma once

#include "preprocess/hlod_format.h"
#include "preprocess/progress.h"

#include <string>

namespace strata {

struct VerifyReport {
    uint64_t cubes = 0, vertices = 0, triangles = 0;
    bool watertight = false;  // level L has no boundary edge (and then, checked, neither has any level)
    bool boundary_locked = false;  // the model says its boundary is locked, and every level has level L's
    bool embedding = false;  // an embedding file, whose section EMBD parses and fits its raster
};

class VerifyError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Throws VerifyError (or std::runtime_error for unreadable data) with "<file>: <what is wrong>".
// Checks: checksums and decoding of every payload; the octree (a root, a parent for every cube);
// every vertex within σ0·s_l of its cell; d∞(v, P(v)) ≤ σ0·s_{l+1}; every parent copy equal to a
// vertex of the parent cube; a cube's triangles mapped by P equal its parent's matching part up to
// degenerate triangles and cyclic rotation; each level watertight if level L is; with a locked boundary
// (MODL flag bit 3), each level's open edges decoding to level L's floats; per-cube error and ε_q; a
// terrain's heights (section HGHT) whole and decodable; an embedding's section EMBD (read_embedding: its
// zone inside the raster, its cells level m − 1's) and a standing site's embedding without cubes.
VerifyReport verify_hlod(const HlodFile& file, const Progress& progress = {});

}  // namespace strata
