// CullVisitor: walks the graph for one view, accumulating transforms, dropping subtrees whose bound
// is outside the frustum (tested in each node's own frame), and collecting draw items and lights.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

#include "engine/scene/camera.h"
#include "engine/scene/frustum.h"
#include "engine/scene/render_list.h"
#include "engine/scene/visitor.h"

namespace strata {

// A view a coming frame will have (a camera path's next pose, the eye's motion carried ahead): its
// camera and the clip-from-world matrix it would draw with. Streamed drawables prefetch for it.
struct Lookahead {
    std::shared_ptr<const Camera> camera;
    glm::dmat4 clip_from_world;
};

struct CullStats {
    uint64_t nodes_visited = 0;
    uint64_t nodes_culled = 0;  // subtrees dropped by the frustum
    uint64_t bound_tests = 0;   // bounds tested against planes (none below a wholly visible node)
    uint64_t stand_ins = 0;     // streamed cubes standing in for children not yet loaded: drawn, or holding drawn ones back
    uint64_t fading = 0;        // streamed cubes whose children are still fading in, or held back
};

class CullVisitor : public NodeVisitor {
public:
    // `view` and `projection` as the renderer draws with them (the camera's, with its clip planes).
    CullVisitor(const Camera& camera, const glm::dmat4& view, const glm::dmat4& projection, RenderList& out);

    void set_traversal_mask(uint32_t mask) { traversal_mask_ = mask; }
    // Off: everything in view or not is emitted (the crack check gathers whole models).
    void set_frustum_culling(bool on) { culling_ = on; }
    bool frustum_culling() const { return culling_; }

    void apply(Node& node) override;
    void apply(Group& group) override;
    void apply(Transform& transform) override;
    void apply(Drawable& drawable) override;
    void apply(Camera& camera) override;
    void apply(DirectionalLight& light) override;
    void apply(AmbientLight& light) override;

    // For drawables during their cull(): the current frame and what it sees.
    const Camera& camera() const { return camera_; }
    const glm::dmat4& model() const { return state_.back().model; }
    const Frustum& local_frustum() const { return state_.back().frustum; }
    uint8_t plane_mask() const { return state_.back().mask; }
    glm::dvec3 local_eye() const;
    // Adds a draw item for `drawable` in the current frame; `data` becomes its item_data range.
    void add(Drawable& drawable, const uint32_t* data = nullptr, uint32_t count = 0, std::shared_ptr<const void> state = nullptr);
    RenderList& list() { return out_; }
    void count_stand_ins(uint64_t count) { stats_.stand_ins += count; }
    void count_fading(uint64_t count) { stats_.fading += count; }
    void set_lookahead(std::vector<Lookahead> views) { lookahead_ = std::move(views); }
    // A full-detail frame (RenderSettings::full_detail): streamed drawables draw what a model loaded
    // whole draws once resident, without the transitions of interactive frames.
    void set_full_detail(bool on) { full_detail_ = on; }
    bool full_detail() const { return full_detail_; }
    const std::vector<Lookahead>& lookahead() const { return lookahead_; }
    const CullStats& stats() const { return stats_; }

private:
    struct Frame {
        glm::dmat4 model;
        Frustum frustum;
        uint8_t mask;
    };
    // Frustum test of the node's bound in the current frame; false when the subtree is out.
    bool enter(Node& node, uint8_t& mask);

    const Camera& camera_;
    glm::dmat4 view_;
    glm::dvec3 eye_world_;
    RenderList& out_;
    uint32_t traversal_mask_ = ~0u;
    bool culling_ = true;
    bool full_detail_ = false;
    std::vector<Frame> state_;
    std::vector<Lookahead> lookahead_;
    CullStats stats_;
};

}  // namespace strata
