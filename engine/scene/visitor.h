// NodeVisitor: one apply() per node type; each falls back to the next more general type, so a
// visitor overrides only what it cares about.
#pragma once

#include <functional>
#include <vector>

#include "engine/scene/node.h"

namespace strata {

class Camera;
class Drawable;
class DirectionalLight;
class AmbientLight;

class NodeVisitor {
public:
    virtual ~NodeVisitor() = default;

    virtual void apply(Node& node) { traverse(node); }
    virtual void apply(Group& group) { apply(static_cast<Node&>(group)); }
    virtual void apply(Transform& transform) { apply(static_cast<Group&>(transform)); }
    virtual void apply(Drawable& drawable);
    virtual void apply(Camera& camera);
    virtual void apply(DirectionalLight& light);
    virtual void apply(AmbientLight& light);

protected:
    // Visits the children of `node` (if any), then runs `after`: where a visitor undoes what it set up
    // for them (a transform's frame). The children wait on this visitor's own stack, not the C stack:
    // a call made while a walk runs (from an apply) queues them and returns at once, the outermost call
    // runs the walk, so a graph of any depth is walked with a few frames of C stack.
    void traverse(Node& node, std::function<void()> after = {});

private:
    friend class Group;
    void queue(Node& child) { pending_.push_back(&child); }

    // Nodes to visit, and nullptr where the last of `afters_` runs: once the nodes above it on the stack
    // are visited. Kept apart, so the stack that every node passes through holds only pointers.
    std::vector<Node*> pending_;
    std::vector<std::function<void()>> afters_;
    bool walking_ = false;
};

}  // namespace strata
