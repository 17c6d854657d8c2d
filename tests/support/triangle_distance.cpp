#include "tests/support/triangle_distance.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace strata::test {

namespace {

constexpr uint32_t kLeafTriangles = 4;

glm::dvec3 closest_point_on_segment(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
    const glm::dvec3 ab = b - a;
    const double length_squared = glm::dot(ab, ab);
    if (length_squared == 0) return a;
    return a + std::clamp(glm::dot(p - a, ab) / length_squared, 0.0, 1.0) * ab;
}

inline double squared(const glm::dvec3& v) { return glm::dot(v, v); }

// Squared Euclidean distance from p to a box: 0 inside.
inline double squared_distance(const glm::dvec3& p, const Box& box) {
    return squared(glm::max(glm::max(box.lo - p, p - box.hi), glm::dvec3(0.0)));
}

}  // namespace

glm::dvec3 closest_point_on_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const glm::dvec3 ab = b - a, ac = c - a;
    if (glm::cross(ab, ac) == glm::dvec3(0.0)) {
        // Collinear corners: the longest edge spans the other two.
        const double lab = squared(ab), lac = squared(ac), lbc = squared(c - b);
        if (lab >= lac && lab >= lbc) return closest_point_on_segment(p, a, b);
        return lac >= lbc ? closest_point_on_segment(p, a, c) : closest_point_on_segment(p, b, c);
    }
    const glm::dvec3 ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return a;
    const glm::dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
    const glm::dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
    // Inside the face: barycentric coordinates from the three sub-areas.
    const double denominator = 1.0 / (va + vb + vc);
    return a + ab * (vb * denominator) + ac * (vc * denominator);
}

TriangleDistance::TriangleDistance(std::vector<glm::dvec3> positions, std::span<const uint32_t> indices)
    : positions_(std::move(positions)) {
    if (indices.size() % 3) throw std::invalid_argument("triangle indices come in threes");
    triangles_.resize(indices.size() / 3);
    std::vector<glm::dvec3> centroids(triangles_.size());
    for (uint32_t t = 0; t < triangles_.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = indices[3 * size_t(t) + k];
            if (v >= positions_.size()) throw std::invalid_argument("a triangle index lies past the positions");
            triangles_[t].corner[k] = v;
        }
        triangles_[t].original = t;
        centroids[t] = (positions_[triangles_[t].corner[0]] + positions_[triangles_[t].corner[1]] +
                        positions_[triangles_[t].corner[2]]) / 3.0;
    }
    if (!triangles_.empty()) {
        nodes_.reserve(2 * (triangles_.size() / kLeafTriangles + 1));
        build(0, uint32_t(triangles_.size()), centroids);
    }
    slot_of_.resize(triangles_.size());
    for (uint32_t slot = 0; slot < triangles_.size(); ++slot) slot_of_[triangles_[slot].original] = slot;
}

Box TriangleDistance::box_of(uint32_t first, uint32_t count) const {
    Box box;
    for (uint32_t t = first; t < first + count; ++t)
        for (const uint32_t v : triangles_[t].corner) box.expand(positions_[v]);
    return box;
}

// Splits at the median centroid along the longest side of the centroids' box: a balanced tree whose
// boxes stay compact on scans, whose triangles are all of a similar size.
uint32_t TriangleDistance::build(uint32_t first, uint32_t count, std::vector<glm::dvec3>& centroids) {
    const uint32_t index = uint32_t(nodes_.size());
    nodes_.emplace_back();
    if (count <= kLeafTriangles) {
        nodes_[index].box = box_of(first, count);
        nodes_[index].first = first;
        nodes_[index].count = count;
        return index;
    }
    Box spread;
    for (uint32_t t = first; t < first + count; ++t) spread.expand(centroids[triangles_[t].original]);
    const glm::dvec3 size = spread.size();
    const int axis = size.x >= size.y && size.x >= size.z ? 0 : size.y >= size.z ? 1 : 2;
    const uint32_t half = count / 2;
    std::nth_element(triangles_.begin() + first, triangles_.begin() + first + half, triangles_.begin() + first + count,
                     [&](const Triangle& a, const Triangle& b) {
                         return centroids[a.original][axis] < centroids[b.original][axis];
                     });
    build(first, half, centroids);
    const uint32_t second = build(first + half, count - half, centroids);
    nodes_[index].second_child = second;
    // The children's boxes are done: their union is this node's.
    nodes_[index].box = nodes_[index + 1].box;
    nodes_[index].box.expand(nodes_[second].box);
    return index;
}

void TriangleDistance::test(const Triangle& t, const glm::dvec3& p, double& best_squared, NearestPoint& best) const {
    const glm::dvec3 q = closest_point_on_triangle(p, positions_[t.corner[0]], positions_[t.corner[1]], positions_[t.corner[2]]);
    const double d = squared(q - p);
    if (d < best_squared || (d == best_squared && t.original < best.triangle)) {
        best_squared = d;
        best.point = q;
        best.triangle = t.original;
    }
}

NearestPoint TriangleDistance::nearest(const glm::dvec3& p, uint32_t hint) const {
    NearestPoint best;
    if (nodes_.empty()) return best;
    double best_squared = std::numeric_limits<double>::infinity();
    if (hint < slot_of_.size()) test(triangles_[slot_of_[hint]], p, best_squared, best);
    struct Pending {
        uint32_t node;
        double squared_distance;
    };
    Pending stack[64];
    int top = 0;
    stack[top++] = {0, squared_distance(p, nodes_[0].box)};
    while (top > 0) {
        const Pending pending = stack[--top];
        if (pending.squared_distance > best_squared) continue;
        const BvhNode& node = nodes_[pending.node];
        if (node.count) {
            for (uint32_t t = node.first; t < node.first + node.count; ++t) test(triangles_[t], p, best_squared, best);
            continue;
        }
        // The nearer child goes on top, so it is searched first and tightens the bound for the other.
        Pending near{pending.node + 1, squared_distance(p, nodes_[pending.node + 1].box)};
        Pending far{node.second_child, squared_distance(p, nodes_[node.second_child].box)};
        if (far.squared_distance < near.squared_distance) std::swap(near, far);
        if (far.squared_distance <= best_squared) stack[top++] = far;
        if (near.squared_distance <= best_squared) stack[top++] = near;
    }
    best.distance = std::sqrt(best_squared);
    return best;
}

NearestPoint TriangleDistance::nearest_by_brute_force(const glm::dvec3& p) const {
    NearestPoint best;
    double best_squared = std::numeric_limits<double>::infinity();
    for (const Triangle& t : triangles_) test(t, p, best_squared, best);
    best.distance = std::sqrt(best_squared);
    return best;
}

}  // namespace strata::test
