#include "editor/navigator.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/quaternion.hpp>

namespace strata {

void Navigator::reset() {
    target_ = bounds_.center();
    camera_.look_at(target_ + glm::dvec3(0.4, 0.3, 1.0), target_);
    camera_.frame(bounds_);
    distance_ = glm::length(camera_.position - target_);
}

void Navigator::follow_camera() {
    distance_ = std::max(glm::length(bounds_.center() - camera_.position), 1e-6 * bounds_.radius());
    target_ = camera_.position + camera_.forward() * distance_;
}

void Navigator::rotate(double dx, double dy) {
    const double speed = 0.005;
    const glm::dquat yaw = glm::angleAxis(-dx * speed, glm::dvec3(0, 1, 0));
    const glm::dquat pitch = glm::angleAxis(-dy * speed, camera_.orientation * glm::dvec3(1, 0, 0));
    camera_.orientation = glm::normalize(yaw * pitch * camera_.orientation);
    if (!fly_) camera_.position = target_ - camera_.forward() * distance_;
}

void Navigator::zoom(double steps) {
    distance_ *= std::pow(0.9, steps);
    distance_ = std::max(distance_, 1e-6 * bounds_.radius());
    if (fly_) camera_.position += camera_.forward() * steps * 0.05 * bounds_.radius();
    else camera_.position = target_ - camera_.forward() * distance_;
}

void Navigator::pan(double dx, double dy) {
    const double scale = (fly_ ? bounds_.radius() : distance_) * 0.002;
    const glm::dvec3 move = camera_.orientation * glm::dvec3(-dx * scale, dy * scale, 0);
    camera_.position += move;
    target_ += move;
}

void Navigator::fly(const glm::dvec3& direction, double seconds) {
    // A third of the scene's radius per second: the same feel for a statue and for a whole site.
    const glm::dvec3 step = camera_.orientation * direction * (0.3 * bounds_.radius() * seconds);
    camera_.position += step;
    target_ += step;
}

}  // namespace strata
