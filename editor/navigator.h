// The camera control of the viewer and the editor: orbit about a target (left drag), zoom (right drag,
// wheel), pan (middle drag), or fly (W A S D Q E and mouse look), with speeds scaled to the scene.
#pragma once

#include <glm/glm.hpp>

#include "engine/scene/bounds.h"
#include "engine/scene/camera.h"

namespace strata {

class Navigator {
public:
    Navigator(Camera& camera, const Box& bounds) : camera_(camera), bounds_(bounds) {}

    // Looks at the scene from the front-right, framed.
    void reset();
    // The camera was moved from outside (a bookmark, the path, a script): orbit about the point ahead
    // of it, as far as the scene's centre.
    void follow_camera();
    // The scene's bounds, refreshed each frame: models come and go.
    void set_bounds(const Box& bounds) { bounds_ = bounds; }

    void toggle_fly() { fly_ = !fly_; }
    bool flying() const { return fly_; }

    void rotate(double dx, double dy);  // pixels dragged
    void zoom(double steps);            // wheel steps, > 0 towards the target
    void pan(double dx, double dy);     // pixels dragged
    // Fly mode: moves along the view axes by `direction` (camera frame) for `seconds`.
    void fly(const glm::dvec3& direction, double seconds);

private:
    double scene_radius() const;  // the scale of every speed
    glm::dvec3 scene_center() const;

    Camera& camera_;
    Box bounds_;
    glm::dvec3 target_{0};
    double distance_ = 1;
    bool fly_ = false;
};

}  // namespace strata
