// Drawable: a node that puts triangles on screen. Node types in nodes/ (Geometry, the HLOD model)
// bring their own cull logic, which emits draw items, their own draw, which the renderer calls, and
// their own ray test, which picking calls.
#pragma once

#include <optional>

#include "engine/scene/node.h"
#include "engine/scene/ray.h"

namespace strata {

class CullVisitor;
struct DrawContext;
struct DrawItem;

class Drawable : public Node {
public:
    void accept(NodeVisitor& visitor) override;

    // Called when the node's bound meets the view frustum: add draw items through cull.add().
    virtual void cull(CullVisitor& cull) = 0;
    // Before any item of the frame is drawn: compute passes an item's draw reads (the renderer runs
    // them all first, so that a GPU overlaps them with nothing waiting, and a software rasterizer need
    // not finish the triangles drawn so far before each). Nothing by default.
    virtual void prepare(DrawContext&, const DrawItem&) {}
    // Issue the GL for one item this drawable emitted (current context, state set by the renderer).
    virtual void draw(DrawContext& context, const DrawItem& item) = 0;
    // The nearest point within [ray.t_min, ray.t_max] where `ray` (in this node's frame) meets the
    // triangles this drawable draws for `context.camera`; none by default (nothing to pick).
    virtual std::optional<SurfaceHit> intersect(const Ray&, const PickContext&) const { return std::nullopt; }
};

}  // namespace strata
