// The view frustum as six planes a·x + b·y + c·z + d ≥ 0 (inside), for clip space with x, y in
// [−w, w] and z in [0, w]. Planes move into a child frame with one matrix product, so culling tests
// each node's own bound in its own frame, without transforming boxes.
#pragma once

#include <array>
#include <cstdint>

#include <glm/glm.hpp>

#include "engine/scene/bounds.h"

namespace strata {

struct Frustum {
    std::array<glm::dvec4, 6> planes;

    // From a projection × view (× model) matrix: the frustum in that matrix's input frame.
    static Frustum from_matrix(const glm::dmat4& clip_from_frame);
    // The same frustum in a child frame, given child → this frame.
    Frustum in_child_frame(const glm::dmat4& child_to_this) const;
};

// Bit k of a plane mask set: plane k still has to be tested. All six: kAllPlanes.
constexpr uint8_t kAllPlanes = 0x3f;

// Tests `box` against the planes in `mask`; returns false when it is wholly outside one of them.
// Clears from `mask` the planes the box is wholly inside, so nothing below it tests them again.
bool intersects(const Frustum& frustum, const Box& box, uint8_t& mask);

}  // namespace strata
