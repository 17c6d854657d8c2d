// NodeVisitor: one apply() per node type; each falls back to the next more general type, so a
// visitor overrides only what it cares about.
#pragma once

#include "engine/scene/node.h"

namespace strata {

class Camera;
class Drawable;
class DirectionalLight;
class AmbientLight;

class NodeVisitor {
public:
    virtual ~NodeVisitor() = default;

    virtual void apply(Node& node) { node.traverse(*this); }
    virtual void apply(Group& group) { apply(static_cast<Node&>(group)); }
    virtual void apply(Transform& transform) { apply(static_cast<Group&>(transform)); }
    virtual void apply(Drawable& drawable);
    virtual void apply(Camera& camera);
    virtual void apply(DirectionalLight& light);
    virtual void apply(AmbientLight& light);
};

}  // namespace strata
