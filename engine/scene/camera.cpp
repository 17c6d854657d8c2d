#include "engine/scene/camera.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/scene/visitor.h"

namespace strata {

void Camera::accept(NodeVisitor& visitor) { visitor.apply(*this); }

void Camera::set_view(const Camera& other) {
    position = other.position;
    orientation = other.orientation;
    projection = other.projection;
    fov_y_degrees = other.fov_y_degrees;
    ortho_height = other.ortho_height;
    near_clip = other.near_clip;
    far_clip = other.far_clip;
    width = other.width;
    height = other.height;
}

void Camera::look_at(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up_hint) {
    position = eye;
    glm::dvec3 direction = target - eye;
    if (glm::length(direction) == 0) return;  // nowhere to look: keep the orientation
    direction = glm::normalize(direction);
    // Looking straight along `up` leaves the roll undefined: take the axis least aligned with the view.
    glm::dvec3 up = up_hint;
    if (glm::length(glm::cross(direction, up)) < 1e-9) {
        const glm::dvec3 a = glm::abs(direction);
        up = a.x <= a.y && a.x <= a.z ? glm::dvec3(1, 0, 0) : a.y <= a.z ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1);
    }
    orientation = glm::quatLookAtRH(direction, up);
}

void Camera::frame(const Box& box) {
    if (!box.valid()) return;
    const double radius = std::max(box.radius(), 1e-9);
    double distance;
    if (projection == ProjectionKind::perspective) {
        const double tan_half = std::min(std::tan(glm::radians(fov_y_degrees) / 2), tan_half_fov_x());
        distance = radius / std::sin(std::atan(tan_half));
    } else {
        ortho_height = 2 * radius * std::max(1.0, 1.0 / aspect());
        distance = 2 * radius;
    }
    position = box.center() - forward() * distance;
}

double Camera::tan_half_fov_x() const {
    if (projection == ProjectionKind::orthographic) return 0;
    return std::tan(glm::radians(fov_y_degrees) / 2) * aspect();
}

glm::dmat4 Camera::view_matrix() const {
    glm::dmat4 pose = glm::mat4_cast(orientation);
    pose[3] = glm::dvec4(position, 1.0);
    return glm::inverse(pose);
}

std::pair<double, double> Camera::clip_planes_for(const Box& scene) const {
    if (near_clip > 0 && far_clip > near_clip) return {near_clip, far_clip};
    // Depths of the scene box's corners along the view direction.
    const glm::dvec3 f = forward();
    double nearest = 1e300, farthest = -1e300;
    for (int corner = 0; corner < 8; ++corner) {
        const glm::dvec3 p{corner & 1 ? scene.hi.x : scene.lo.x, corner & 2 ? scene.hi.y : scene.lo.y,
                           corner & 4 ? scene.hi.z : scene.lo.z};
        const double depth = glm::dot(p - position, f);
        nearest = std::min(nearest, depth);
        farthest = std::max(farthest, depth);
    }
    if (!scene.valid() || farthest <= 0) return {0.01, 100.0};  // nothing ahead: any planes will do
    const double margin = 0.01 * (farthest - std::min(nearest, farthest)) + 1e-9 * farthest;
    if (projection == ProjectionKind::orthographic) return {nearest - margin, farthest + margin};
    // Reversed float depth keeps precision for near/far ratios far beyond 10⁵; the near plane only has
    // to stay in front of the eye, and close to the surface when the eye is inside the scan's box.
    const double far = farthest + margin;
    return {std::max(nearest - margin, far * 1e-6), far};
}

glm::dmat4 Camera::projection_matrix(double near, double far) const {
    // Reversed depth: glm's zero-to-one matrices with near and far swapped map near → 1, far → 0.
    if (projection == ProjectionKind::orthographic) {
        const double half_h = ortho_height / 2, half_w = half_h * aspect();
        return glm::orthoRH_ZO(-half_w, half_w, -half_h, half_h, far, near);
    }
    return glm::perspectiveRH_ZO(glm::radians(fov_y_degrees), aspect(), far, near);
}

}  // namespace strata
