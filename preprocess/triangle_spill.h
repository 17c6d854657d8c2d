// The builder's second pass (000 §3.3.2, "scan 2"): every proper triangle of the input, its corners'
// values copied in, appended to the run of the level-L block its cell lies in (a RunSpill), in input
// order.
#pragma once

#include <cstddef>

#include "preprocess/build_cubes.h"
#include "preprocess/run_spill.h"
#include "preprocess/triangle_source.h"

namespace strata::build {

// One corner as the spill stores it: position, then the kept attributes (normal, colour, UV).
struct CornerLayout {
    static constexpr size_t kMostBytes = 36;  // with every attribute
    AttributeSet kept;
    size_t bytes() const { return 12 + (kept.normals ? 12 : 0) + (kept.colors ? 4 : 0) + (kept.uvs ? 8 : 0); }
    size_t normal_offset() const { return 12; }
    size_t color_offset() const { return 12 + (kept.normals ? 12 : 0); }
    size_t uv_offset() const { return color_offset() + (kept.colors ? 4 : 0); }
};

// Appends the batch's proper triangles to their level-f.max_level blocks' runs; returns how many.
size_t spill_triangles(const TriangleBatch& batch, const Frame& f, const CornerLayout& layout, RunSpill& spill);

}  // namespace strata::build
