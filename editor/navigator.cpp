#include "editor/navigator.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/quaternion.hpp>

namespace strata {

double Navigator::scene_radius() const {
    // An empty scene has no bounds: move as if it were a unit's size rather than by its infinite extent.
    const double radius = bounds_.valid() ? bounds_.radius() : 0.0;
    return radius > 0 ? radius : 1.0;
}

glm::dvec3 Navigator::scene_center() const { return bounds_.valid() ? bounds_.center() : glm::dvec3(0); }

void Navigator::reset() {
    target_ = scene_center();
    camera_.look_at(target_ + glm::dvec3(0.4, 0.3, 1.0), target_);
    if (bounds_.valid()) camera_.frame(bounds_);
    distance_ = glm::length(camera_.position - target_);
    placed();
}

void Navigator::follow_camera() {
    distance_ = std::max(glm::length(scene_center() - camera_.position), 1e-6 * scene_radius());
    target_ = camera_.position + camera_.forward() * distance_;
    placed();
}

void Navigator::follow_if_moved() {
    if (camera_.position != placed_position_ || camera_.orientation != placed_orientation_) follow_camera();
}

void Navigator::placed() {
    placed_position_ = camera_.position;
    placed_orientation_ = camera_.orientation;
}

void Navigator::rotate(double dx, double dy) {
    const double speed = 0.005;
    const glm::dquat yaw = glm::angleAxis(-dx * speed, glm::dvec3(0, 1, 0));
    const glm::dquat pitch = glm::angleAxis(-dy * speed, camera_.orientation * glm::dvec3(1, 0, 0));
    camera_.orientation = glm::normalize(yaw * pitch * camera_.orientation);
    if (!fly_) camera_.position = target_ - camera_.forward() * distance_;
    placed();
}

void Navigator::zoom(double steps) {
    distance_ *= std::pow(0.9, steps);
    distance_ = std::max(distance_, 1e-6 * scene_radius());
    if (fly_) camera_.position += camera_.forward() * steps * 0.05 * scene_radius();
    else camera_.position = target_ - camera_.forward() * distance_;
    placed();
}

void Navigator::pan(double dx, double dy) {
    const double scale = (fly_ ? scene_radius() : distance_) * 0.002;
    const glm::dvec3 move = camera_.orientation * glm::dvec3(-dx * scale, dy * scale, 0);
    camera_.position += move;
    target_ += move;
    placed();
}

void Navigator::fly(const glm::dvec3& direction, double seconds) {
    // A third of the scene's radius per second: the same feel for a statue and for a whole site.
    const glm::dvec3 step = camera_.orientation * direction * (0.3 * scene_radius() * seconds);
    camera_.position += step;
    target_ += step;
    placed();
}

}  // namespace strata
