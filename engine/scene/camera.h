// Camera: a pose (position and orientation; the camera looks down its −Z with +Y up, as in OpenGL)
// and a projection. Depth is reversed (near → 1, far → 0, clip z in [0, w]) for float depth
// precision over the long view distances of large scans.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/scene/bounds.h"
#include "engine/scene/node.h"

namespace strata {

enum class ProjectionKind { perspective, orthographic };

class Camera : public Node {
public:
    void accept(NodeVisitor& visitor) override;

    glm::dvec3 position{0, 0, 0};
    glm::dquat orientation{1, 0, 0, 0};

    ProjectionKind projection = ProjectionKind::perspective;
    double fov_y_degrees = 50.0;     // perspective: the vertical field of view
    double ortho_height = 2.0;       // orthographic: the height of the view volume
    double near_clip = 0.0;          // both 0: chosen from the scene's bounds (clip_planes_for)
    double far_clip = 0.0;
    int width = 1280, height = 720;  // the image, in pixels

    // Takes `other`'s pose, lens and image size (a camera is a node of the graph: it is not copied).
    void set_view(const Camera& other);
    // Points the camera at `target` from `eye`, with `up` as close to its +Y as it can be.
    void look_at(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up = {0, 1, 0});
    // Moves the camera back along its view direction until `box` fits the view (keeps orientation).
    void frame(const Box& box);

    double aspect() const { return double(width) / double(height); }
    glm::dvec3 forward() const { return orientation * glm::dvec3(0, 0, -1); }
    glm::dvec3 up() const { return orientation * glm::dvec3(0, 1, 0); }
    // tan of half the horizontal field of view (the θ of DESIGN.md §3's screen-space error bound).
    double tan_half_fov_x() const;

    glm::dmat4 view_matrix() const;
    // Near and far planes: the explicit ones, or the tightest around `scene` (world frame).
    std::pair<double, double> clip_planes_for(const Box& scene) const;
    glm::dmat4 projection_matrix(double near, double far) const;
};

}  // namespace strata
