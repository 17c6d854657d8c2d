// Exact distances from points to a triangle mesh, in double precision: a bounding volume hierarchy
// over the triangles, searched nearest box first and pruned by the best distance found so far, and
// the exact closest point on each triangle it reaches. The fidelity measurement's reference
// (tests/support/fidelity.h); nothing in the engine needs distances to surfaces.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "engine/scene/bounds.h"

namespace strata::test {

// The point of triangle a, b, c nearest to p (Ericson, Real-Time Collision Detection §5.1.5, by
// Voronoi regions). A degenerate triangle is treated as its longest edge, which then holds every
// point of it.
glm::dvec3 closest_point_on_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);

struct NearestPoint {
    double distance = std::numeric_limits<double>::infinity();
    glm::dvec3 point{0.0};
    uint32_t triangle = ~0u;  // index of the triangle (three entries of the indices given), or ~0u
};

class TriangleDistance {
public:
    // Triangles as three indices each into `positions`. Keeps its own copy of both.
    TriangleDistance(std::vector<glm::dvec3> positions, std::span<const uint32_t> indices);

    // The nearest point of any triangle to p; none (infinite distance) when there are no triangles.
    // `hint`, a triangle likely near p (the answer for a neighbouring point), bounds the search from
    // the start: the same answer, found sooner.
    NearestPoint nearest(const glm::dvec3& p, uint32_t hint = ~0u) const;
    // The same by testing every triangle: the reference nearest() must equal.
    NearestPoint nearest_by_brute_force(const glm::dvec3& p) const;

    size_t triangle_count() const { return triangles_.size(); }

private:
    struct Triangle {
        uint32_t corner[3];
        uint32_t original;  // its index in the order given
    };
    // A node covers triangles_[first, first + count) when a leaf (count > 0); else its children are
    // nodes_[index + 1] and nodes_[second_child].
    struct BvhNode {
        Box box;
        uint32_t first = 0, count = 0, second_child = 0;
    };

    uint32_t build(uint32_t first, uint32_t count, std::vector<glm::dvec3>& centroids);
    Box box_of(uint32_t first, uint32_t count) const;
    // Tests triangle t against p, keeping the nearer of it and `best` (squared distance).
    void test(const Triangle& t, const glm::dvec3& p, double& best_squared, NearestPoint& best) const;

    std::vector<glm::dvec3> positions_;
    std::vector<Triangle> triangles_;  // in leaf order
    std::vector<uint32_t> slot_of_;    // a triangle's index in triangles_, by its original index
    std::vector<BvhNode> nodes_;       // depth first, the root at 0
};

}  // namespace strata::test
