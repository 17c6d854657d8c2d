// Picking an HLOD model: a ray against the triangles as drawn for the pick's camera. The selection
// runs along the ray only (the cubes whose cull boxes it meets, by the rule select() applies), best
// first: boxes in the order the ray enters them, so the search stops at the first box entered beyond
// the nearest hit, and only the cubes that get that far are morphed and their triangles tested.
#include <queue>
#include <vector>

#include "engine/scene/camera.h"
#include "nodes/hlod_model.h"

namespace strata {

namespace {

// A cube whose cull box the ray enters at `entry`; the queue hands out the nearest first.
struct Candidate {
    double entry;
    uint32_t cube;
    bool operator>(const Candidate& other) const { return entry > other.entry; }
};

}  // namespace

HlodModel::MorphInputs HlodModel::morph_inputs(const PickContext& view, std::vector<uint32_t>* drawn) const {
    // The κ the view's selection morphs with, band ends of capped cubes included.
    Kappas kappa;
    std::vector<uint32_t> selection;
    select(view_for(view.camera, view.local_eye()), drawn ? *drawn : selection, &kappa);
    return {anchor_for(view.world_from_node, view.eye_world), std::move(kappa), morphs_for(view.camera)};
}

void HlodModel::drawn_positions(uint32_t c, const MorphInputs& inputs, std::vector<glm::vec3>& out) const {
    if (inputs.morph) {
        morphed_positions(c, inputs.anchor, *inputs.kappa, out);
        return;
    }
    const HlodCube& cube = tree_->cubes[c];
    out.resize(cube.data->vertex_count());
    for (uint32_t v = 0; v < out.size(); ++v) out[v] = anchored_position(cube.node.level, lattice_steps(cube, v), inputs.anchor);
}

std::optional<SurfaceHit> HlodModel::intersect(const Ray& ray, const PickContext& context) const {
    const Camera& camera = context.camera;
    const HlodView view = view_for(camera, context.local_eye());
    std::vector<uint32_t> drawn;
    const MorphInputs inputs = morph_inputs(context, &drawn);
    const std::shared_ptr<const CubeRuns> runs = hook_ ? hook_(drawn, inputs.kappa) : nullptr;
    // The lattice frame is the node's frame shifted by −O, the drawn positions' by −O − E: the same
    // parameter t names the same point in all three.
    Ray lattice_ray = ray;
    lattice_ray.origin -= origin();
    Ray anchored_ray = lattice_ray;
    anchored_ray.origin -= inputs.anchor.origin;

    std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> queue;
    auto enqueue = [&](uint32_t c) {
        if (const std::optional<double> t = entry(lattice_ray, cull_box(tree_->cubes[c].node))) queue.push({*t, c});
    };
    enqueue(tree_->root);
    std::optional<SurfaceHit> nearest;
    std::vector<glm::vec3> positions;
    Capping capping(*this, view);
    while (!queue.empty()) {
        const Candidate next = queue.top();
        queue.pop();
        // A cube's box holds its children's boxes, so nothing still queued or below it starts nearer.
        if (next.entry > anchored_ray.t_max) break;
        const HlodCube& cube = tree_->cubes[next.cube];
        if (!tree_->resident[next.cube]) continue;  // only a streamed model's root, before it arrives
        if (!drawn_here(next.cube, view, capping)) {
            for (const uint32_t child : cube.children)
                if (child != kNoCube) enqueue(child);
            continue;
        }
        drawn_positions(next.cube, inputs, positions);
        const std::span<const uint32_t> indices = cube.data->indices;
        const auto hidden = runs ? runs->find(next.cube) : CubeRuns::const_iterator{};
        std::optional<SurfaceHit> hit;
        auto test = [&](std::span<const uint32_t> triangles) {
            const auto found = nearest_triangle(anchored_ray, triangles, [&](uint32_t v) { return glm::dvec3(positions[v]); });
            if (found && (!hit || found->t < hit->t)) hit = found;
        };
        if (runs && hidden != runs->end()) {
            for (const auto& run : hidden->second) test(indices.subspan(run[0], run[1]));
        } else {
            test(indices);
        }
        if (!hit) continue;
        // Drawn here without being suitable: a stand-in, or capped beside one.
        nearest = SurfaceHit{hit->t, hit->normal, next.cube, !suitable(next.cube, view)};
        anchored_ray.t_max = lattice_ray.t_max = hit->t;
    }
    return nearest;
}

}  // namespace strata
