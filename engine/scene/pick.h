// Picking: what a click selects. A PickVisitor walks a scene with a ray, carrying it into each
// Transform's frame, skipping hidden nodes and subtrees whose bound the ray misses, and asks each
// drawable where the ray meets what it draws; pick() does it for a camera and a pixel.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "engine/scene/camera.h"
#include "engine/scene/ray.h"
#include "engine/scene/visitor.h"

namespace strata {

struct PickHit {
    Node* node;           // the drawable hit
    glm::dvec3 point;     // world frame
    glm::dvec3 normal;    // world frame, unit, on the side the ray comes from
    double distance;      // from the ray's origin to the point, in world units
    uint32_t cube;        // the HLOD cube drawn there (an index into HlodModel::cubes()), or kNoHitCube
    bool provisional;     // what is drawn there is a stand-in for data still loading (SurfaceHit)
};

class PickVisitor : public NodeVisitor {
public:
    // `ray` in the frame of the node the visitor is applied to (the world); `camera` is the view the
    // pick is made in: each drawable is tested as it draws for that camera.
    PickVisitor(const Camera& camera, const Ray& ray);

    void set_traversal_mask(uint32_t mask) { traversal_mask_ = mask; }

    void apply(Node& node) override;
    void apply(Transform& transform) override;
    void apply(Drawable& drawable) override;
    void apply(Camera& camera) override;

    // The nearest hit so far: after the traversal, the pick's answer.
    const std::optional<PickHit>& nearest() const { return nearest_; }

private:
    struct Frame {
        glm::dmat4 world_from_frame;
        Ray ray;  // in this frame
    };
    // The current frame's ray, cut short at the nearest hit so far.
    Ray current_ray() const;
    // False when the node is hidden or the ray misses its bound.
    bool enter(const Node& node) const;

    const Camera& camera_;
    glm::dvec3 eye_world_;
    uint32_t traversal_mask_ = ~0u;
    std::vector<Frame> frames_;
    std::optional<PickHit> nearest_;
    double nearest_t_ = std::numeric_limits<double>::infinity();  // its ray parameter
};

// The ray through the centre of pixel (floor(x), floor(y)) of `camera`'s image (pixels from the
// top-left corner, as Image rows are stored; a cursor position in pixels picks the pixel it is over),
// limited to the view depths `near` … `far`. Its direction is a unit vector; its origin is the eye, or
// for an orthographic camera the point on the camera's plane (then t is the view depth, which is
// negative for what lies behind that plane but beyond the near plane).
Ray camera_ray(const Camera& camera, double x, double y, double near, double far);

// The nearest surface drawn at pixel (x, y) when `scene` is rendered with `camera` (its clip planes
// fitted to the scene as the renderer fits them), or none where the pixel shows the background.
std::optional<PickHit> pick(Node& scene, const Camera& camera, double x, double y);

}  // namespace strata
