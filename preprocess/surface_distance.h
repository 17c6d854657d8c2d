// Conservative distances between triangle surfaces: the builder's error bound (FORMAT.md §4.2,
// "error"). For surfaces X and Y it bounds the one-sided distance sup_{x∈X} min_{y∈Y} (|x − y| + o(y)),
// where o is an offset per triangle of Y (the bound Y itself already carries against the full
// resolution, so that the triangle inequality chains the levels). The result's `upper` is never
// below the true value; `lower` is a value actually attained, so `upper − lower` says how tight it is.
//
// How (a branch and bound over pieces of X's triangles):
// - lower: exact closest-point distances at piece corners;
// - upper, three ways, the least wins:
//   * Lipschitz: d(·, Y) moves at most one per unit, so a piece is within d(corner) + its reach;
//   * one target triangle: distance to a convex set is convex, so over a piece it peaks at a corner;
//   * height field: along the piece's normal, the part of Y above the piece (its facing triangles,
//     projected onto the piece's plane, clipped to it, checked not to overlap) is a graph; the
//     vertical gap is linear over each clipped polygon and peaks at its corners. Uncovered area a
//     (Y ends, or folds away) adds sqrt(a/π), the farthest an uncovered point can be from a covered one.
//   A piece whose upper bound is within the tolerance of the largest lower bound found so far in its
//   group cannot raise the group's maximum: it is settled; others split in four.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace strata {

// Positions (x y z floats) and triangles (three indices each) of one surface.
struct SurfaceView {
    std::span<const float> positions;
    std::span<const uint32_t> triangles;
    uint32_t triangle_count() const { return uint32_t(triangles.size() / 3); }
};

// A bounding-volume hierarchy over a surface's triangles, each with an offset (≥ 0) added to the
// distance of any point to it.
class TriangleTree {
public:
    TriangleTree(SurfaceView surface, std::span<const float> offsets);

    struct Nearest {
        double distance = 1e300;  // |x − y| + o(y), minimal over the surface
        uint32_t triangle = ~0u;
    };
    // The nearest triangle to a point (+inf and ~0u when there is none). `hint`, a triangle likely
    // near (the answer for a neighbouring point), bounds the search from the start: the same distance,
    // found sooner.
    Nearest nearest(const double point[3], uint32_t hint = ~0u) const;
    // Calls `visit(triangle)` for every triangle whose box meets [lo, hi].
    template <class Visit>
    void overlapping(const double lo[3], const double hi[3], Visit&& visit) const;

    SurfaceView surface() const { return surface_; }
    double offset(uint32_t triangle) const { return offsets_.empty() ? 0.0 : offsets_[triangle]; }
    // The triangles that use vertex v.
    std::span<const uint32_t> around(uint32_t v) const {
        return std::span(around_).subspan(around_first_[v], around_first_[v + 1] - around_first_[v]);
    }
    // The triangle's unit normal (zero for a degenerate one).
    const float* normal(uint32_t triangle) const { return &normals_[3 * size_t(triangle)]; }
    bool empty() const { return nodes_.empty(); }

private:
    struct Node {
        float lo[3], hi[3];
        float min_offset;
        uint32_t first;  // leaf: first entry in order_; inner: left child (right child is first + 1)
        uint32_t count;  // leaf: triangles; inner: 0
    };
    void build(uint32_t index, uint32_t begin, uint32_t end, const std::vector<float>& centroids);

    SurfaceView surface_;
    std::span<const float> offsets_;
    std::vector<uint32_t> order_;
    std::vector<Node> nodes_;
    std::vector<float> normals_;
    std::vector<uint32_t> around_first_, around_;  // triangles by vertex: around_[around_first_[v] …]
};

struct DistanceBound {
    double lower = 0;  // attained: some point of X is this far
    double upper = 0;  // no point of X is farther
};

// The bound per group (groups[t] names triangle t's group, < group_count), within `tolerance` of the
// true maximum unless a piece hit the depth limit. A group with no triangles gets {0, 0}; an empty
// target gives +inf.
std::vector<DistanceBound> directed_distance(SurfaceView from, std::span<const uint32_t> groups, uint32_t group_count,
                                             const TriangleTree& to, double tolerance);

// The exact distance from a point to a triangle (double precision).
double point_triangle_distance(const double p[3], const double a[3], const double b[3], const double c[3]);

template <class Visit>
void TriangleTree::overlapping(const double lo[3], const double hi[3], Visit&& visit) const {
    if (nodes_.empty()) return;
    uint32_t stack[64];
    uint32_t top = 0;
    stack[top++] = 0;
    while (top) {
        const Node& n = nodes_[stack[--top]];
        bool meets = true;
        for (int a = 0; a < 3; ++a) meets = meets && n.lo[a] <= hi[a] && n.hi[a] >= lo[a];
        if (!meets) continue;
        if (n.count) {
            for (uint32_t i = n.first; i < n.first + n.count; ++i) visit(order_[i]);
        } else {
            stack[top++] = n.first;
            stack[top++] = n.first + 1;
        }
    }
}

}  // namespace strata
