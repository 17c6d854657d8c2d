// Rays for picking, in double precision: a segment of a half-line, its tests against boxes and
// triangles, and what a drawable answers when asked where a ray meets what it draws.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <span>

#include <glm/glm.hpp>

#include "engine/scene/bounds.h"

namespace strata {

class Camera;

// The points origin + t·direction for t in [t_min, t_max]. Moved into another frame by an affine
// matrix (direction not renormalized), a ray keeps its parameter: the same t names the same point in
// every frame, so hits found in different nodes' frames compare by t alone.
struct Ray {
    glm::dvec3 origin{0.0};
    glm::dvec3 direction{0.0, 0.0, -1.0};
    double t_min = 0;
    double t_max = std::numeric_limits<double>::infinity();

    glm::dvec3 at(double t) const { return origin + t * direction; }
    // The same ray in the frame `to_frame` maps into (origin as a point, direction as a vector).
    Ray transformed(const glm::dmat4& to_frame) const;
};

// The parameter at which `ray` enters `box` (t_min when it starts inside), or none when the two do
// not meet within [t_min, t_max]. An invalid (empty) box is never entered.
std::optional<double> entry(const Ray& ray, const Box& box);

// Möller–Trumbore, both faces (the renderer draws both): the parameter at which `ray` crosses the
// triangle a, b, c within [t_min, t_max], or none. A degenerate triangle is never crossed.
std::optional<double> crossing(const Ray& ray, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);

// For SurfaceHit::cube: the hit is not in an HLOD cube.
inline constexpr uint32_t kNoHitCube = ~0u;

// Where a ray meets a drawable, in the drawable's frame.
struct SurfaceHit {
    double t;
    glm::dvec3 normal;             // the face normal of the triangle hit: any length, either side
    uint32_t cube = kNoHitCube;    // the HLOD model's cube drawn there
    // Drawn coarser than the view wants because finer data is not resident yet (a streamed model's
    // stand-in): a full-detail frame would draw something finer there.
    bool provisional = false;
};

// The nearest crossing of `ray` with indexed triangles (three indices each), and its face normal.
// `position(v)` gives vertex v in the ray's frame.
template <class PositionOf>
std::optional<SurfaceHit> nearest_triangle(Ray ray, std::span<const uint32_t> indices, PositionOf position) {
    std::optional<SurfaceHit> nearest;
    for (size_t i = 0; i + 2 < indices.size(); i += 3) {
        const glm::dvec3 a = position(indices[i]), b = position(indices[i + 1]), c = position(indices[i + 2]);
        if (const std::optional<double> t = crossing(ray, a, b, c)) {
            nearest = SurfaceHit{*t, glm::cross(b - a, c - a)};
            ray.t_max = *t;  // only nearer ones count from here on
        }
    }
    return nearest;
}

// What a drawable needs to know of the pick: the camera the scene is seen with (what a drawable
// draws may depend on it, as an HLOD model's selection and morph do), and where the drawable is.
struct PickContext {
    const Camera& camera;
    glm::dmat4 world_from_node;  // composed as the cull pass composes it
    glm::dvec3 eye_world;        // as the renderer derives it from the view matrix

    // The eye in the drawable's frame, in the same arithmetic as CullVisitor::local_eye().
    glm::dvec3 local_eye() const { return glm::dvec3(glm::inverse(world_from_node) * glm::dvec4(eye_world, 1.0)); }
};

}  // namespace strata
