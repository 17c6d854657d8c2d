// Lights: a directional light (a sun; direction in the node's frame, so a Transform turns it) and an
// ambient term. The renderer uses a headlight when a scene has no light at all.
#pragma once

#include <glm/glm.hpp>

#include "engine/scene/node.h"

namespace strata {

class DirectionalLight : public Node {
public:
    void accept(NodeVisitor& visitor) override;

    // The direction the light travels (from the light towards the scene), in this node's frame.
    glm::dvec3 direction{0, 0, -1};
    glm::vec3 color{1, 1, 1};
    float intensity = 1.0f;
};

class AmbientLight : public Node {
public:
    void accept(NodeVisitor& visitor) override;

    glm::vec3 color{0.15f, 0.15f, 0.15f};
};

}  // namespace strata
