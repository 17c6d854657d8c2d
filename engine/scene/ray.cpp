#include "engine/scene/ray.h"

#include <algorithm>

namespace strata {

Ray Ray::transformed(const glm::dmat4& to_frame) const {
    return {glm::dvec3(to_frame * glm::dvec4(origin, 1.0)), glm::dmat3(to_frame) * direction, t_min, t_max};
}

std::optional<double> entry(const Ray& ray, const Box& box) {
    if (!box.valid()) return std::nullopt;
    // Slabs: the parameter interval inside each pair of planes, intersected.
    double near = ray.t_min, far = ray.t_max;
    for (int axis = 0; axis < 3; ++axis) {
        const double o = ray.origin[axis], d = ray.direction[axis];
        if (d == 0) {  // parallel to the slab: inside it everywhere or nowhere
            if (o < box.lo[axis] || o > box.hi[axis]) return std::nullopt;
            continue;
        }
        const double t0 = (box.lo[axis] - o) / d, t1 = (box.hi[axis] - o) / d;
        near = std::max(near, std::min(t0, t1));
        far = std::min(far, std::max(t0, t1));
        if (near > far) return std::nullopt;
    }
    return near;
}

std::optional<double> crossing(const Ray& ray, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    const glm::dvec3 edge1 = b - a, edge2 = c - a;
    const glm::dvec3 p = glm::cross(ray.direction, edge2);
    const double determinant = glm::dot(edge1, p);
    if (determinant == 0) return std::nullopt;  // the ray runs in the triangle's plane, or no triangle
    const double inverse = 1.0 / determinant;
    const glm::dvec3 s = ray.origin - a;
    const double u = glm::dot(s, p) * inverse;
    if (u < 0 || u > 1) return std::nullopt;
    const glm::dvec3 q = glm::cross(s, edge1);
    const double v = glm::dot(ray.direction, q) * inverse;
    if (v < 0 || u + v > 1) return std::nullopt;
    const double t = glm::dot(edge2, q) * inverse;
    if (t < ray.t_min || t > ray.t_max) return std::nullopt;
    return t;
}

}  // namespace strata
