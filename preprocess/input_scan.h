// The builder's first pass over its input (000 §3.3.2, "scan 1"): what the frame, L and σ0 are chosen
// from, gathered triangle by triangle so that nothing of the mesh is kept.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "preprocess/build_cubes.h"
#include "preprocess/progress.h"
#include "preprocess/triangle_source.h"

namespace strata::build {

struct InputScan {
    uint64_t triangles = 0;   // proper ones: degenerate triangles are skipped, as weld() drops them
    uint64_t degenerate = 0;  // those with two corners at one position
    // The extent of the proper triangles' corners, and of every corner (for telling the user why a
    // mesh has no proper triangles).
    std::array<double, 3> low{INFINITY, INFINITY, INFINITY}, high{-INFINITY, -INFINITY, -INFINITY};
    std::array<double, 3> corner_low{INFINITY, INFINITY, INFINITY}, corner_high{-INFINITY, -INFINITY, -INFINITY};
    float longest_edge = 0;  // in the max norm, the quantity constraint 1 bounds by σ0·s_L
    // The barycenter of every `stride`-th proper triangle (a power of two, doubled whenever the sample
    // would pass kMaxSample), for choosing L.
    std::vector<std::array<double, 3>> sample;
    uint64_t stride = 1;

    static constexpr size_t kMaxSample = 1 << 17;
};

// Reads every source once. Throws InputError naming the source for a non-finite coordinate.
InputScan scan_inputs(const std::vector<std::unique_ptr<TriangleSource>>& sources, const Progress& progress);

// The frame of the proper triangles' extent (its origin the extent's low corner, its root the longest
// side). Throws InputError naming `source` when every vertex lies at one point.
Frame make_frame(const InputScan& scan, const std::string& source);

// The smallest L below `max_levels` at which the typical triangle's cell holds at most `leaf`
// triangles; `max_levels` when none does.
uint32_t choose_levels(const InputScan& scan, const Frame& f, int leaf, uint32_t max_levels);

}  // namespace strata::build
