// Rotation: look-at orientations, hemisphere alignment, slerp and squad for camera paths.
#include "engine/path/rotation.h"

#include <algorithm>
#include <cmath>

namespace strata {

glm::dquat look_at_orientation(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up_hint) {
    const glm::dvec3 direction = glm::normalize(target - eye);
    glm::dvec3 up = glm::normalize(up_hint);
    if (glm::length(glm::cross(direction, up)) < 1e-9) {
        const glm::dvec3 a = glm::abs(direction);
        up = a.x <= a.y && a.x <= a.z ? glm::dvec3(1, 0, 0) : a.y <= a.z ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
    }
    return glm::normalize(glm::quatLookAtRH(direction, up));
}

void align_hemispheres(std::vector<glm::dquat>& keys) {
    for (size_t i = 1; i < keys.size(); ++i)
        if (glm::dot(keys[i - 1], keys[i]) < 0) keys[i] = -keys[i];
}

glm::dquat slerp_arc(const glm::dquat& a, const glm::dquat& b, double u) {
    const double cosine = std::clamp(glm::dot(a, b), -1.0, 1.0);
    const double angle = std::acos(cosine);
    // Nearly equal: sin(angle) → 0 in the denominator; the chord is the arc to within rounding.
    if (std::sin(angle) < 1e-9) return glm::normalize(a * (1 - u) + b * u);
    const double sine = std::sin(angle);
    return glm::normalize(a * (std::sin((1 - u) * angle) / sine) + b * (std::sin(u * angle) / sine));
}

namespace {

// log of a unit quaternion (cos θ, n sin θ): the pure quaternion (0, n θ).
glm::dvec3 log_unit(const glm::dquat& q) {
    const glm::dvec3 v(q.x, q.y, q.z);
    const double sine = glm::length(v);
    if (sine < 1e-15) return glm::dvec3(0);
    return v * (std::atan2(sine, q.w) / sine);
}

glm::dquat exp_pure(const glm::dvec3& v) {
    const double angle = glm::length(v);
    if (angle < 1e-15) return glm::dquat(1, 0, 0, 0);
    const glm::dvec3 axis = v * (std::sin(angle) / angle);
    return glm::dquat(std::cos(angle), axis.x, axis.y, axis.z);
}

}  // namespace

std::vector<glm::dquat> squad_controls(const std::vector<glm::dquat>& q) {
    std::vector<glm::dquat> controls(q);
    for (size_t i = 1; i + 1 < q.size(); ++i) {
        const glm::dquat inverse = glm::conjugate(q[i]);
        const glm::dvec3 sum = log_unit(inverse * q[i + 1]) + log_unit(inverse * q[i - 1]);
        controls[i] = glm::normalize(q[i] * exp_pure(-sum / 4.0));
    }
    return controls;
}

glm::dquat squad(const glm::dquat& a, const glm::dquat& b, const glm::dquat& sa, const glm::dquat& sb, double u) {
    return slerp_arc(slerp_arc(a, b, u), slerp_arc(sa, sb, u), 2 * u * (1 - u));
}

}  // namespace strata
