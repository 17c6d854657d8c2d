// Axis-aligned bounding boxes in double precision: scans carry survey coordinates (metres from a
// distant origin), where float loses millimetres.
#pragma once

#include <glm/glm.hpp>

namespace strata {

struct Box {
    glm::dvec3 lo{1e300};
    glm::dvec3 hi{-1e300};

    static Box from(const glm::dvec3& lo, const glm::dvec3& hi) { return {lo, hi}; }
    bool valid() const { return lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z; }
    glm::dvec3 center() const { return 0.5 * (lo + hi); }
    glm::dvec3 size() const { return hi - lo; }
    double radius() const { return 0.5 * glm::length(hi - lo); }

    void expand(const glm::dvec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    void expand(const Box& b) {
        if (!b.valid()) return;
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
    bool contains(const glm::dvec3& p) const {
        return glm::all(glm::lessThanEqual(lo, p)) && glm::all(glm::lessThanEqual(p, hi));
    }
};

// The box around `box` after `matrix` (an affine local-to-parent transform): exact for the eight
// corners, so never smaller than the transformed content.
Box transformed(const Box& box, const glm::dmat4& matrix);

}  // namespace strata
