// Drawable: a node that puts triangles on screen. Node types in nodes/ (Geometry, the HLOD model)
// bring their own cull logic, which emits draw items, and their own draw, which the renderer calls.
#pragma once

#include "engine/scene/node.h"

namespace strata {

class CullVisitor;
struct DrawContext;
struct DrawItem;

class Drawable : public Node {
public:
    void accept(NodeVisitor& visitor) override;

    // Called when the node's bound meets the view frustum: add draw items through cull.add().
    virtual void cull(CullVisitor& cull) = 0;
    // Issue the GL for one item this drawable emitted (current context, state set by the renderer).
    virtual void draw(DrawContext& context, const DrawItem& item) = 0;
};

}  // namespace strata
