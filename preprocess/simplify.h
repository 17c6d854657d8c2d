// QEM half-edge collapse over one block of cubes (000 §3.2.1, §3.2.4). Works on a block-local mesh in
// flat arrays and returns where every vertex went, so the caller can compose the parent map P.
//
// Vertices come in two layers: a *point* is a position (seam copies share one), a *wedge* is a point
// plus attributes. Topology, quadrics, locks and travel bounds live on points; attribute error lives on
// wedges. Collapsing point u into point w moves every wedge of u onto the wedge of w it shares a
// triangle edge with ("the target's copy on the same side"); a collapse where some wedge of u has no
// such partner, or two, would smear attributes across a seam and is refused.
#pragma once

#include <cstdint>
#include <vector>

namespace strata {

struct BlockMesh {
    std::vector<float> point_positions;   // x y z per point, in the block's own normalized frame
    std::vector<uint8_t> point_locked;    // per point: 1 = may not move (block border); may be a target
    std::vector<uint32_t> wedge_point;    // per wedge: its point
    std::vector<float> wedge_attributes;  // attribute_count per wedge, already scaled by their weights
    uint32_t attribute_count = 0;
    std::vector<uint32_t> triangles;      // three wedges per triangle

    uint32_t point_count() const { return uint32_t(point_locked.size()); }
    uint32_t wedge_count() const { return uint32_t(wedge_point.size()); }
    uint32_t triangle_count() const { return uint32_t(triangles.size() / 3); }
};

struct SimplifyLimits {
    uint32_t target_triangles = 0;  // stop when at most this many triangles are left
    float max_error = 1e30f;        // stop before a collapse whose error (frame units) exceeds this
    float max_travel = 1e30f;       // d∞ from the target to every point merged into the collapsed one
    // A collapse that moves a point at most this far (d∞) skips the fold test, and such a neighbour is
    // a point's first choice of target. Below the next level's lattice step a fold is gone once
    // positions are quantized, while a pocket that small whose every collapse folds (or meets a
    // zero-area triangle) would otherwise outlive every level: on the lattice, two faces on one edge.
    float min_fold = 0;
};

struct SimplifyResult {
    std::vector<uint32_t> wedge_remap;  // per wedge: the wedge it finally became (itself if it survived)
    std::vector<float> point_error;     // per point: largest geometric error collapsed into it so far
    uint32_t triangles_left = 0;
};

// Deterministic: the same BlockMesh and limits give the same result, on any thread.
SimplifyResult simplify_block(const BlockMesh& mesh, const SimplifyLimits& limits);

}  // namespace strata
