// The cull benchmark: one cull traversal of the same ~100 000-node scene by Strata's CullVisitor and by
// OpenSceneGraph 3.6's osgUtil::CullVisitor (Debian's libopenscenegraph-dev, a benchmark-only
// dependency). Times the cull pass only (no scene construction, no drawing) and prints the ratio
// beside its target (Strata ≤ 0.5 × OpenSceneGraph). Asserts nothing.
//
//   bench_cull [--nodes 100000] [--runs 50] [--warmup 5] [--seed 1] [--geodes] [--osg-sort-by-state]
//
// The scene, built from one deterministic description in both libraries:
//   root Group
//   └ 16 Transforms (level 1: spread over 2 km × 2 km, random rotation, uniform scale 0.5–2)
//     └ 16 Groups each (clusters: no matrix of their own, children kept within ±40 m of a random centre)
//       └ 16 Transforms each (level 3: random rotation, uniform scale 0.5–2)
//         └ L leaves each: a box of 12 triangles (8 vertices, 36 indices), 0.4–2 m on a side, within ±10 m
// with L chosen to make --nodes (23 for 100 000: 98 577 nodes, 94 208 leaves). A Strata leaf is a Drawable
// subclass whose compute_bound() goes over its 8 vertices and whose cull() calls cull.add(*this); an OSG
// leaf is an osg::Geometry (vertex array + DrawElementsUByte) added straight under the Transform, as OSG
// 3.4+ allows (one node per leaf in both graphs), or with --geodes wrapped in an osg::Geode as older OSG
// code does (one more node and one more cull test per leaf on OSG's side only).
//
// The camera looks down obliquely at the scene so that about half of the leaves are outside the view
// frustum (the program prints the fraction). Both sides cull against the same six planes:
//   - Strata computes no near/far in the cull pass (the camera's planes are fixed before), so OSG runs
//     with DO_NOT_COMPUTE_NEAR_FAR and the same near and far planes.
//   - OSG's default culling mode adds small-feature culling (drops nodes under 2 pixels) and tests only
//     the frustum's sides; Strata has neither, so OSG runs with VIEW_FRUSTUM_CULLING only (sides, near
//     and far): the same test, and both sides then emit the same leaves.
//   - Strata sorts its draw items front to back; OSG's opaque bin sorts by state by default, which for this
//     scene (no StateSets: one StateGraph) sorts nothing. OSG's render stage is set to SORT_FRONT_TO_BACK so
//     both sort the emitted leaves by depth; --osg-sort-by-state keeps OSG's default instead.
// Per frame each side resets what it reuses from the previous frame (Strata: RenderList::clear(); OSG:
// CullVisitor::reset(), StateGraph::clean(), RenderStage::reset(), StateGraph::prune() after the sort, as
// osgUtil::SceneView::cullStage does), inside the timed region. The two run alternately, iteration by
// iteration, so machine noise falls on both alike.
#include "engine/scene/cull_visitor.h"
#include "engine/scene/drawable.h"
#include "tests/bench/bench_stats.h"

#include <osg/Geode>
#include <osg/Geometry>
#include <osg/MatrixTransform>
#include <osg/Viewport>
#include <osgUtil/CullVisitor>
#include <osgUtil/RenderStage>
#include <osgUtil/StateGraph>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

using strata::bench::median;

// The twelve triangles of a box over corners numbered by bits (x: 1, y: 2, z: 4), outward facing.
constexpr std::array<uint8_t, 36> kBoxIndices = {0, 2, 3, 0, 3, 1,  4, 5, 7, 4, 7, 6,  0, 1, 5, 0, 5, 4,
                                                 2, 6, 7, 2, 7, 3,  0, 4, 6, 0, 6, 2,  1, 3, 7, 1, 7, 5};

// The scene as one library-neutral tree, so both graphs are the same.
struct SpecNode {
    enum Kind { group, transform, leaf } kind;
    glm::dmat4 matrix{1.0};                 // transform: child → parent
    std::array<glm::vec3, 8> corners{};     // leaf: the box's vertices
    std::vector<uint32_t> children;
};

struct Scene {
    std::vector<SpecNode> nodes;  // nodes[0] is the root
    uint32_t leaves = 0;
};

Scene make_scene(int leaves_per_transform, uint32_t seed) {
    std::mt19937_64 rng(seed);
    auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    auto random_matrix = [&](const glm::dvec3& translation) {
        const glm::dvec3 axis = glm::normalize(glm::dvec3(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)) + glm::dvec3(1e-9));
        const glm::dquat rotation = glm::angleAxis(uniform(0, 2 * M_PI), axis);
        const double scale = uniform(0.5, 2.0);
        return glm::translate(glm::dmat4(1.0), translation) * glm::mat4_cast(rotation) * glm::scale(glm::dmat4(1.0), glm::dvec3(scale));
    };
    Scene scene;
    auto add = [&](uint32_t parent, SpecNode::Kind kind, const glm::dmat4& matrix = glm::dmat4(1.0)) {
        scene.nodes.push_back({kind, matrix, {}, {}});
        const uint32_t index = uint32_t(scene.nodes.size() - 1);
        if (index != 0) scene.nodes[parent].children.push_back(index);
        return index;
    };
    const uint32_t root = add(0, SpecNode::group);
    for (int a = 0; a < 16; ++a) {
        const uint32_t t1 = add(root, SpecNode::transform, random_matrix({uniform(-1000, 1000), uniform(-1000, 1000), uniform(-50, 50)}));
        for (int b = 0; b < 16; ++b) {
            const uint32_t g = add(t1, SpecNode::group);
            const glm::dvec3 centre{uniform(-200, 200), uniform(-200, 200), uniform(-200, 200)};
            for (int c = 0; c < 16; ++c) {
                const glm::dvec3 offset{uniform(-40, 40), uniform(-40, 40), uniform(-40, 40)};
                const uint32_t t3 = add(g, SpecNode::transform, random_matrix(centre + offset));
                for (int d = 0; d < leaves_per_transform; ++d) {
                    const glm::vec3 at(uniform(-10, 10), uniform(-10, 10), uniform(-10, 10));
                    const glm::vec3 half(uniform(0.2, 1), uniform(0.2, 1), uniform(0.2, 1));
                    SpecNode& leaf = scene.nodes[add(t3, SpecNode::leaf)];
                    for (int k = 0; k < 8; ++k)
                        leaf.corners[k] = at + glm::vec3(k & 1 ? half.x : -half.x, k & 2 ? half.y : -half.y, k & 4 ? half.z : -half.z);
                    ++scene.leaves;
                }
            }
        }
    }
    return scene;
}

// ---- Strata ----

class BoxDrawable : public strata::Drawable {
public:
    BoxDrawable(const std::array<glm::vec3, 8>& corners, uint32_t index) : corners_(corners), index(index) {}
    void cull(strata::CullVisitor& cull) override { cull.add(*this); }
    void draw(strata::DrawContext&, const strata::DrawItem&) override {}  // culling only: never drawn

protected:
    strata::Box compute_bound() const override {
        strata::Box box;
        for (const glm::vec3& v : corners_) box.expand(glm::dvec3(v));
        return box;
    }

private:
    std::array<glm::vec3, 8> corners_;

public:
    const uint32_t index;  // in the scene description, to compare what the two emit
};

strata::NodePtr build_strata(const Scene& scene, uint32_t i) {
    const SpecNode& spec = scene.nodes[i];
    if (spec.kind == SpecNode::leaf) return std::make_shared<BoxDrawable>(spec.corners, i);
    std::shared_ptr<strata::Group> group;
    if (spec.kind == SpecNode::transform) {
        auto transform = std::make_shared<strata::Transform>();
        transform->set_matrix(spec.matrix);
        group = transform;
    } else {
        group = std::make_shared<strata::Group>();
    }
    for (uint32_t child : spec.children) group->add(build_strata(scene, child));
    return group;
}

// ---- OpenSceneGraph ----

osg::ref_ptr<osg::Node> build_osg(const Scene& scene, uint32_t i, bool geodes, osg::DrawElementsUByte* triangles,
                                  std::unordered_map<const osg::Drawable*, uint32_t>& leaf_index) {
    const SpecNode& spec = scene.nodes[i];
    if (spec.kind == SpecNode::leaf) {
        osg::ref_ptr<osg::Vec3Array> vertices = new osg::Vec3Array;
        for (const glm::vec3& v : spec.corners) vertices->push_back(osg::Vec3(v.x, v.y, v.z));
        osg::ref_ptr<osg::Geometry> geometry = new osg::Geometry;
        geometry->setVertexArray(vertices.get());
        geometry->addPrimitiveSet(triangles);
        leaf_index[geometry.get()] = i;
        if (!geodes) return geometry;
        osg::ref_ptr<osg::Geode> geode = new osg::Geode;
        geode->addDrawable(geometry.get());
        return geode;
    }
    osg::ref_ptr<osg::Group> group;
    if (spec.kind == SpecNode::transform)
        // glm's column-major matrix and OSG's row-major, row-vector one have the same memory layout.
        group = new osg::MatrixTransform(osg::Matrixd(glm::value_ptr(spec.matrix)));
    else
        group = new osg::Group;
    for (uint32_t child : spec.children) group->addChild(build_osg(scene, child, geodes, triangles, leaf_index).get());
    return group;
}

// Render leaves in a render bin and its sub-bins: in the StateGraphs until a sort moves them to the leaf list.
size_t count_leaves(const osgUtil::RenderBin& bin, std::vector<const osg::Drawable*>* out = nullptr) {
    size_t n = 0;
    auto take = [&](const osgUtil::RenderLeaf* leaf) {
        ++n;
        if (out) out->push_back(leaf->getDrawable());
    };
    for (const osgUtil::RenderLeaf* leaf : bin.getRenderLeafList()) take(leaf);
    for (const osgUtil::StateGraph* graph : bin.getStateGraphList())
        for (const auto& leaf : graph->_leaves) take(leaf.get());
    for (const auto& [number, sub] : bin.getRenderBinList()) n += count_leaves(*sub, out);
    return n;
}

size_t count_nodes(const osg::Node& node) {
    size_t n = 1;
    if (const osg::Group* group = node.asGroup())
        for (unsigned i = 0; i < group->getNumChildren(); ++i) n += count_nodes(*group->getChild(i));
    return n;
}

size_t count_nodes(const strata::Node& node) {
    size_t n = 1;
    if (auto* group = dynamic_cast<const strata::Group*>(&node))
        for (const strata::NodePtr& child : group->children()) n += count_nodes(*child);
    return n;
}

}  // namespace

int main(int argc, char** argv) {
    int target_nodes = 100000, runs = 50, warmup = 5;
    uint32_t seed = 1;
    bool geodes = false, osg_sort_by_state = false;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto value = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
        if (a == "--nodes") target_nodes = std::stoi(value());
        else if (a == "--runs") runs = std::max(1, std::stoi(value()));
        else if (a == "--warmup") warmup = std::max(0, std::stoi(value()));
        else if (a == "--seed") seed = uint32_t(std::stoul(value()));
        else if (a == "--geodes") geodes = true;
        else if (a == "--osg-sort-by-state") osg_sort_by_state = true;
        else {
            std::fprintf(stderr, "usage: bench_cull [--nodes N] [--runs N] [--warmup N] [--seed N] [--geodes] [--osg-sort-by-state]\n");
            return 2;
        }
    }
    // 1 + 16 + 256 + 4096 inner nodes; the rest are leaves, spread evenly over the 4096 level-3 transforms.
    const int leaves_per_transform = std::max(1, int(std::lround((target_nodes - 4369) / 4096.0)));
    const Scene scene = make_scene(leaves_per_transform, seed);

    // The view: 1280 × 720, 50° vertical field of view, from 600 m above the scene and 300 m south of its
    // centre, looking north and 34° down: what lies behind, beside and below is out (about half the leaves
    // with the default seed). Near and far planes fixed, as Strata's renderer sets them before culling.
    strata::Camera camera;
    camera.width = 1280, camera.height = 720;
    camera.fov_y_degrees = 50;
    camera.look_at({0, -300, 600}, {0, 600, 0}, {0, 0, 1});
    const double near = 1.0, far = 20000.0;
    const glm::dmat4 view = camera.view_matrix();
    const glm::dmat4 projection = camera.projection_matrix(near, far);

    // Strata.
    strata::NodePtr strata_root = build_strata(scene, 0);
    strata_root->bound();  // bounds are cached; computed here as a renderer's first frame would
    strata::RenderList list;
    strata::CullStats strata_stats;
    auto cull_strata = [&] {
        const auto start = Clock::now();
        list.clear();
        strata::CullVisitor cull(camera, view, projection, list);
        strata_root->accept(cull);
        list.sort();
        const double ms = ms_since(start);
        strata_stats = cull.stats();
        return ms;
    };

    // OpenSceneGraph: a CullVisitor run by hand, as osgUtil::SceneView::cullStage runs it, without a
    // window or a graphics context (culling needs neither).
    std::unordered_map<const osg::Drawable*, uint32_t> osg_leaf_index;
    osg::ref_ptr<osg::DrawElementsUByte> triangles =
        new osg::DrawElementsUByte(GL_TRIANGLES, kBoxIndices.size(), kBoxIndices.data());
    osg::ref_ptr<osg::Node> osg_root = build_osg(scene, 0, geodes, triangles.get(), osg_leaf_index);
    osg_root->getBound();
    osg::ref_ptr<osg::Viewport> viewport = new osg::Viewport(0, 0, camera.width, camera.height);
    osg::ref_ptr<osg::RefMatrixd> osg_projection = new osg::RefMatrixd(osg::Matrixd::perspective(
        camera.fov_y_degrees, camera.aspect(), near, far));
    osg::ref_ptr<osg::RefMatrixd> osg_view = new osg::RefMatrixd(glm::value_ptr(view));
    osg::ref_ptr<osgUtil::CullVisitor> cv = new osgUtil::CullVisitor;
    osg::ref_ptr<osgUtil::StateGraph> state_graph = new osgUtil::StateGraph;
    osg::ref_ptr<osgUtil::RenderStage> render_stage = new osgUtil::RenderStage;
    cv->setComputeNearFarMode(osg::CullSettings::DO_NOT_COMPUTE_NEAR_FAR);
    cv->setCullingMode(osg::CullSettings::VIEW_FRUSTUM_CULLING);
    if (!osg_sort_by_state) render_stage->setSortMode(osgUtil::RenderBin::SORT_FRONT_TO_BACK);
    auto cull_osg = [&] {
        const auto start = Clock::now();
        cv->reset();
        state_graph->clean();
        render_stage->reset();
        cv->setStateGraph(state_graph.get());
        cv->setRenderStage(render_stage.get());
        render_stage->setViewport(viewport.get());
        cv->pushViewport(viewport.get());
        cv->pushProjectionMatrix(osg_projection.get());
        cv->pushModelViewMatrix(osg_view.get(), osg::Transform::ABSOLUTE_RF);
        osg_root->accept(*cv);
        cv->popModelViewMatrix();
        cv->popProjectionMatrix();
        cv->popViewport();
        render_stage->sort();
        state_graph->prune();
        return ms_since(start);
    };

    for (int i = 0; i < warmup; ++i) cull_strata(), cull_osg();
    std::vector<double> strata_ms, osg_ms;
    for (int i = 0; i < runs; ++i) {
        // Alternate which goes first, so neither always finds the other's data in the caches.
        if (i % 2 == 0) strata_ms.push_back(cull_strata()), osg_ms.push_back(cull_osg());
        else osg_ms.push_back(cull_osg()), strata_ms.push_back(cull_strata());
    }

    // What each emitted, leaf by leaf (after the last run; both keep their output until the next cull).
    std::vector<const osg::Drawable*> osg_drawables;
    const size_t osg_emitted = count_leaves(*render_stage, &osg_drawables);
    std::vector<uint32_t> strata_set, osg_set;
    for (const strata::DrawItem& item : list.opaque) strata_set.push_back(static_cast<BoxDrawable*>(item.drawable)->index);
    for (const osg::Drawable* d : osg_drawables) osg_set.push_back(osg_leaf_index.at(d));
    std::sort(strata_set.begin(), strata_set.end());
    std::sort(osg_set.begin(), osg_set.end());
    std::vector<uint32_t> only_strata, only_osg;
    std::set_difference(strata_set.begin(), strata_set.end(), osg_set.begin(), osg_set.end(), std::back_inserter(only_strata));
    std::set_difference(osg_set.begin(), osg_set.end(), strata_set.begin(), strata_set.end(), std::back_inserter(only_osg));
    bool strata_sorted = std::is_sorted(list.opaque.begin(), list.opaque.end(),
                                        [](const strata::DrawItem& a, const strata::DrawItem& b) { return a.depth < b.depth; });

    const size_t strata_nodes = count_nodes(*strata_root), osg_nodes = count_nodes(*osg_root);
    std::printf("scene: %zu nodes in Strata (%u box leaves of 12 triangles, %d per level-3 transform), %zu in OSG%s\n",
                strata_nodes, scene.leaves, leaves_per_transform, osg_nodes, geodes ? " (each leaf an osg::Geode + osg::Geometry)" : "");
    std::printf("view: %d × %d, %.0f° vertical; %.1f %% of the leaves in view\n", camera.width, camera.height,
                camera.fov_y_degrees, 100.0 * list.opaque.size() / scene.leaves);
    std::printf("emitted: Strata %zu draw items%s, OSG %zu render leaves; only in Strata %zu, only in OSG %zu\n",
                list.opaque.size(), strata_sorted ? " (front to back)" : " (NOT SORTED)", osg_emitted,
                only_strata.size(), only_osg.size());
    std::printf("Strata cull: %llu nodes visited, %llu subtrees culled, %llu bound tests\n",
                (unsigned long long)strata_stats.nodes_visited, (unsigned long long)strata_stats.nodes_culled,
                (unsigned long long)strata_stats.bound_tests);
    const double s_med = median(strata_ms), o_med = median(osg_ms);
    std::printf("Strata cull + sort:  median %.3f ms, min %.3f ms (%d runs after %d warm-up)\n", s_med,
                *std::min_element(strata_ms.begin(), strata_ms.end()), runs, warmup);
    std::printf("OSG cull + sort:     median %.3f ms, min %.3f ms (%s)\n", o_med, *std::min_element(osg_ms.begin(), osg_ms.end()),
                osg_sort_by_state ? "opaque bin sorted by state, OSG's default" : "render stage sorted front to back");
    std::printf("strata / OSG: %.2f (target ≤ 0.5)\n", s_med / o_med);
    return 0;
}
