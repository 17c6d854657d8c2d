#include "engine/scene/pick.h"

#include <algorithm>
#include <cmath>

#include "engine/scene/drawable.h"

namespace strata {

PickVisitor::PickVisitor(const Camera& camera, const Ray& ray)
    : camera_(camera), eye_world_(glm::inverse(camera.view_matrix())[3]) {
    frames_.push_back({glm::dmat4(1.0), ray});
}

Ray PickVisitor::current_ray() const {
    Ray ray = frames_.back().ray;
    ray.t_max = std::min(ray.t_max, nearest_t_);
    return ray;
}

bool PickVisitor::enter(const Node& node) const {
    return (node.mask() & traversal_mask_) && entry(current_ray(), node.bound());
}

void PickVisitor::apply(Node& node) {
    if (enter(node)) traverse(node);
}

void PickVisitor::apply(Transform& transform) {
    if (!enter(transform)) return;  // the bound is in the parent's frame, where the ray still is
    const Frame& parent = frames_.back();
    frames_.push_back({parent.world_from_frame * transform.matrix(), parent.ray.transformed(glm::inverse(transform.matrix()))});
    traverse(transform, [this] { frames_.pop_back(); });
}

void PickVisitor::apply(Drawable& drawable) {
    if (!enter(drawable)) return;
    const Frame& frame = frames_.back();
    const std::optional<SurfaceHit> hit = drawable.intersect(current_ray(), {camera_, frame.world_from_frame, eye_world_});
    if (!hit || hit->t >= nearest_t_) return;
    const Ray& world_ray = frames_.front().ray;
    // Normals go through the inverse transpose; then onto the side the ray comes from (both faces draw).
    glm::dvec3 normal = glm::normalize(glm::transpose(glm::inverse(glm::dmat3(frame.world_from_frame))) * hit->normal);
    if (glm::dot(normal, world_ray.direction) > 0) normal = -normal;
    nearest_t_ = hit->t;
    nearest_ = PickHit{&drawable, world_ray.at(hit->t), normal, hit->t * glm::length(world_ray.direction), hit->cube,
                       hit->provisional};
}

// Cameras in the graph are poses to look through, not things to pick.
void PickVisitor::apply(Camera&) {}

Ray camera_ray(const Camera& camera, double x, double y, double near, double far) {
    // The pixel's centre in normalized device coordinates: x to the right, y up, [−1, 1] across the image.
    const double ndc_x = 2 * (std::floor(x) + 0.5) / camera.width - 1;
    const double ndc_y = 1 - 2 * (std::floor(y) + 0.5) / camera.height;
    Ray ray;
    if (camera.projection == ProjectionKind::orthographic) {
        const double half_height = camera.ortho_height / 2;
        ray.origin = camera.position + camera.orientation * glm::dvec3(ndc_x * half_height * camera.aspect(), ndc_y * half_height, 0);
        ray.direction = camera.forward();
        ray.t_min = near;
        ray.t_max = far;
        return ray;
    }
    const double tan_half_y = std::tan(glm::radians(camera.fov_y_degrees) / 2);
    const glm::dvec3 through_pixel(ndc_x * tan_half_y * camera.aspect(), ndc_y * tan_half_y, -1);  // at view depth 1
    const double length = glm::length(through_pixel);
    ray.origin = camera.position;
    ray.direction = camera.orientation * (through_pixel / length);
    // A unit step along the ray goes 1/length deeper in view depth, where the clip planes are.
    ray.t_min = near * length;
    ray.t_max = far * length;
    return ray;
}

std::optional<PickHit> pick(Node& scene, const Camera& camera, double x, double y) {
    const auto [near, far] = camera.clip_planes_for(scene.bound());  // as Renderer::render chooses them
    PickVisitor visitor(camera, camera_ray(camera, x, y, near, far));
    scene.accept(visitor);
    return visitor.nearest();
}

}  // namespace strata
