// The camera control of the viewer and the editor: orbit about a target (left drag), zoom (right drag,
// wheel), pan (middle drag), or fly (W A S D Q E and mouse look), with speeds scaled to the scene.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

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
    // follow_camera() if anything but the navigator moved the camera since its own last move: its own
    // moves keep the orbit point.
    void follow_if_moved();
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
    void placed();  // after each of its own moves: the pose it left the camera in

    Camera& camera_;
    Box bounds_;
    glm::dvec3 target_{0};
    double distance_ = 1;
    bool fly_ = false;
    glm::dvec3 placed_position_{0};
    glm::dquat placed_orientation_{1, 0, 0, 0};
};

}  // namespace strata
