#include "engine/scene/frustum.h"

namespace strata {

Frustum Frustum::from_matrix(const glm::dmat4& m) {
    // Rows of m (glm is column-major: row i is m[0][i], m[1][i], ...).
    auto row = [&](int i) { return glm::dvec4(m[0][i], m[1][i], m[2][i], m[3][i]); };
    const glm::dvec4 x = row(0), y = row(1), z = row(2), w = row(3);
    return {{w + x, w - x, w + y, w - y, z, w - z}};
}

Frustum Frustum::in_child_frame(const glm::dmat4& child_to_this) const {
    // p·(M x) = (Mᵀ p)·x
    Frustum out;
    const glm::dmat4 transpose = glm::transpose(child_to_this);
    for (int k = 0; k < 6; ++k) out.planes[k] = transpose * planes[k];
    return out;
}

bool intersects(const Frustum& frustum, const Box& box, uint8_t& mask) {
    if (!box.valid()) return false;
    for (int k = 0; k < 6; ++k) {
        if (!(mask & (1u << k))) continue;
        const glm::dvec4& p = frustum.planes[k];
        // The box corner farthest along the plane's normal, and the nearest one.
        const glm::dvec3 far{p.x >= 0 ? box.hi.x : box.lo.x, p.y >= 0 ? box.hi.y : box.lo.y, p.z >= 0 ? box.hi.z : box.lo.z};
        const glm::dvec3 near{p.x >= 0 ? box.lo.x : box.hi.x, p.y >= 0 ? box.lo.y : box.hi.y, p.z >= 0 ? box.lo.z : box.hi.z};
        if (glm::dot(glm::dvec3(p), far) + p.w < 0) return false;
        if (glm::dot(glm::dvec3(p), near) + p.w >= 0) mask &= uint8_t(~(1u << k));
    }
    return true;
}

}  // namespace strata
