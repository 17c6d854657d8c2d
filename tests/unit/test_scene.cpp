// The scene graph core (engine/scene): bounds, groups and transforms, cameras, the frustum and the
// CullVisitor's culling, transforms, lights and draw order.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/render/gpu_cache.h"
#include "engine/scene/camera.h"
#include "engine/scene/cull_visitor.h"
#include "engine/scene/drawable.h"
#include "engine/scene/light.h"
#include "engine/scene/node.h"

namespace strata {
namespace {

// A drawable that occupies a fixed box and emits one item per cull.
class BoxNode : public Drawable {
public:
    explicit BoxNode(Box box, std::string name = {}) : box_(box) { set_name(std::move(name)); }
    void cull(CullVisitor& cull) override { cull.add(*this, &tag, 1); }
    void draw(DrawContext&, const DrawItem&) override {}
    void set_box(Box box) {
        box_ = box;
        dirty_bound();
    }
    uint32_t tag = 7;

protected:
    Box compute_bound() const override { return box_; }

private:
    Box box_;
};

Box unit_box_at(glm::dvec3 c, double half = 0.5) { return Box::from(c - glm::dvec3(half), c + glm::dvec3(half)); }

void expect_near(const glm::dvec3& a, const glm::dvec3& b, double tolerance = 1e-9) {
    EXPECT_NEAR(a.x, b.x, tolerance);
    EXPECT_NEAR(a.y, b.y, tolerance);
    EXPECT_NEAR(a.z, b.z, tolerance);
}

TEST(Bounds, TransformedBoxEnclosesTheRotatedCorners) {
    const Box box = Box::from({0, 0, 0}, {2, 1, 1});
    const glm::dmat4 m = glm::rotate(glm::translate(glm::dmat4(1.0), {10, 0, 0}), glm::radians(90.0), {0, 0, 1});
    const Box out = transformed(box, m);
    // (x, y) → (−y, x), then +10 in x.
    expect_near(out.lo, {9, 0, 0});
    expect_near(out.hi, {10, 2, 1});
    EXPECT_FALSE(transformed(Box{}, m).valid());
}

TEST(Graph, GroupBoundFollowsItsChildren) {
    auto root = std::make_shared<Group>();
    auto a = std::make_shared<BoxNode>(unit_box_at({0, 0, 0}));
    auto moved = std::make_shared<Transform>();
    auto b = std::make_shared<BoxNode>(unit_box_at({0, 0, 0}));
    moved->add(b);
    moved->set_matrix(glm::translate(glm::dmat4(1.0), {5, 0, 0}));
    root->add(a);
    root->add(moved);
    expect_near(root->bound().lo, {-0.5, -0.5, -0.5});
    expect_near(root->bound().hi, {5.5, 0.5, 0.5});
    // A change deep down reaches the root's cached bound.
    b->set_box(unit_box_at({0, 3, 0}));
    expect_near(root->bound().hi, {5.5, 3.5, 0.5});
    moved->set_matrix(glm::dmat4(1.0));
    expect_near(root->bound().hi, {0.5, 3.5, 0.5});
    EXPECT_TRUE(root->remove(moved.get()));
    EXPECT_FALSE(root->remove(moved.get()));
    expect_near(root->bound().hi, {0.5, 0.5, 0.5});
    EXPECT_TRUE(moved->parents().empty());
}

TEST(Graph, RotationAndUniformScaleIsToldFromGeneralMatrices) {
    const glm::dmat4 trs = glm::scale(glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(1, 2, 3)), 0.7, glm::dvec3(1, 1, 0)),
                                      glm::dvec3(2.5));
    EXPECT_TRUE(is_rotation_and_uniform_scale(glm::dmat4(1.0)));
    EXPECT_TRUE(is_rotation_and_uniform_scale(trs));
    EXPECT_FALSE(is_rotation_and_uniform_scale(glm::scale(glm::dmat4(1.0), glm::dvec3(2, 1, 1))));  // stretch
    EXPECT_FALSE(is_rotation_and_uniform_scale(glm::scale(glm::dmat4(1.0), glm::dvec3(-1, -1, -1))));  // mirror
    glm::dmat4 shear(1.0);
    shear[1][0] = 0.3;
    EXPECT_FALSE(is_rotation_and_uniform_scale(shear));
    EXPECT_FALSE(is_rotation_and_uniform_scale(glm::dmat4(0.0)));
    glm::dmat4 projective(1.0);
    projective[0][3] = 0.1;
    EXPECT_FALSE(is_rotation_and_uniform_scale(projective));
}

TEST(Graph, ACycleIsRefused) {
    auto a = std::make_shared<Group>(), b = std::make_shared<Group>();
    a->set_name("a");
    b->set_name("b");
    a->add(b);
    EXPECT_THROW(b->add(a), std::invalid_argument);
    EXPECT_THROW(a->add(a), std::invalid_argument);
    EXPECT_THROW(a->add(nullptr), std::invalid_argument);
    EXPECT_EQ(b->child_count(), 0u);
}

TEST(Graph, NamesIdsMasksAndUserValues) {
    auto root = std::make_shared<Group>();
    auto statue = std::make_shared<BoxNode>(unit_box_at({0, 0, 0}), "statue");
    auto inner = std::make_shared<Transform>();
    inner->add(statue);
    root->add(inner);
    EXPECT_EQ(find_node(*root, "statue"), statue.get());
    EXPECT_EQ(find_node(*root, "tomb"), nullptr);
    EXPECT_NE(statue->id(), 0u);
    EXPECT_NE(statue->id(), inner->id());
    statue->set_user_value("site", std::string("Pompeii"));
    statue->set_user_value("year", 79.0);
    ASSERT_NE(statue->user_value("site"), nullptr);
    EXPECT_EQ(std::get<std::string>(*statue->user_value("site")), "Pompeii");
    EXPECT_EQ(std::get<double>(*statue->user_value("year")), 79.0);
    EXPECT_EQ(statue->user_value("missing"), nullptr);
    statue->set_visible(false);
    EXPECT_FALSE(statue->visible());
}

TEST(Camera, LookAtPointsTheViewAxisAtTheTarget) {
    Camera camera;
    camera.look_at({0, 0, 10}, {0, 0, 0});
    expect_near(camera.forward(), {0, 0, -1});
    expect_near(camera.up(), {0, 1, 0});
    camera.look_at({3, 4, 5}, {3, 4, -7}, {0, 1, 0});
    expect_near(camera.forward(), {0, 0, -1});
    // Straight down the up axis: still a valid orientation.
    camera.look_at({0, 10, 0}, {0, 0, 0}, {0, 1, 0});
    expect_near(camera.forward(), {0, -1, 0});
    EXPECT_NEAR(glm::length(camera.up()), 1.0, 1e-12);
    // The view matrix takes the eye to the origin and the target onto −Z.
    camera.look_at({1, 2, 3}, {1, 2, -5});
    const glm::dmat4 v = camera.view_matrix();
    expect_near(glm::dvec3(v * glm::dvec4(1, 2, 3, 1)), {0, 0, 0});
    expect_near(glm::dvec3(v * glm::dvec4(1, 2, -5, 1)), {0, 0, -8});
}

TEST(Camera, ReversedDepthMapsNearToOneAndFarToZero) {
    Camera camera;
    for (ProjectionKind kind : {ProjectionKind::perspective, ProjectionKind::orthographic}) {
        camera.projection = kind;
        const glm::dmat4 p = camera.projection_matrix(0.5, 200.0);
        const glm::dvec4 at_near = p * glm::dvec4(0, 0, -0.5, 1), at_far = p * glm::dvec4(0, 0, -200, 1);
        EXPECT_NEAR(at_near.z / at_near.w, 1.0, 1e-12);
        EXPECT_NEAR(at_far.z / at_far.w, 0.0, 1e-12);
    }
}

TEST(Camera, FrameFitsTheBoxAndClipPlanesEncloseIt) {
    Camera camera;
    camera.width = 800;
    camera.height = 600;
    camera.look_at({0, 0, 0}, {0, 0, -1});
    const Box box = Box::from({-1, -2, -3}, {4, 5, 6});
    camera.frame(box);
    // Every corner projects inside the image and between the clip planes.
    auto [near, far] = camera.clip_planes_for(box);
    EXPECT_GT(near, 0);
    const glm::dmat4 clip = camera.projection_matrix(near, far) * camera.view_matrix();
    for (int c = 0; c < 8; ++c) {
        glm::dvec4 p = clip * glm::dvec4(c & 1 ? box.hi.x : box.lo.x, c & 2 ? box.hi.y : box.lo.y, c & 4 ? box.hi.z : box.lo.z, 1);
        p /= p.w;
        EXPECT_LE(std::abs(p.x), 1.0);
        EXPECT_LE(std::abs(p.y), 1.0);
        EXPECT_GT(p.z, 0.0);
        EXPECT_LT(p.z, 1.0);
    }
    // Explicit planes win.
    camera.near_clip = 2;
    camera.far_clip = 3;
    EXPECT_EQ(camera.clip_planes_for(box), std::make_pair(2.0, 3.0));
}

TEST(Frustum, BoxesInsideOutsideAndAcross) {
    Camera camera;
    camera.look_at({0, 0, 0}, {0, 0, -1});
    const glm::dmat4 clip = camera.projection_matrix(1, 100) * camera.view_matrix();
    const Frustum f = Frustum::from_matrix(clip);
    uint8_t mask = kAllPlanes;
    EXPECT_TRUE(intersects(f, unit_box_at({0, 0, -10}), mask));
    EXPECT_EQ(mask, 0) << "wholly inside: no plane left to test below it";
    mask = kAllPlanes;
    EXPECT_FALSE(intersects(f, unit_box_at({0, 0, 10}), mask));  // behind the eye
    mask = kAllPlanes;
    EXPECT_FALSE(intersects(f, unit_box_at({0, 0, -200}), mask));  // beyond far
    mask = kAllPlanes;
    EXPECT_FALSE(intersects(f, unit_box_at({100, 0, -10}), mask));  // far to the right
    mask = kAllPlanes;
    EXPECT_TRUE(intersects(f, unit_box_at({0, 0, -100}), mask));  // across the far plane
    EXPECT_NE(mask, 0);
    // In a child frame placed 50 to the right, a box at x = −50 is straight ahead.
    const Frustum child = f.in_child_frame(glm::translate(glm::dmat4(1.0), {50, 0, 0}));
    mask = kAllPlanes;
    EXPECT_TRUE(intersects(child, unit_box_at({-50, 0, -10}), mask));
    mask = kAllPlanes;
    EXPECT_FALSE(intersects(child, unit_box_at({0, 0, -10}), mask));
}

TEST(RenderList, SortIsStableFrontToBackOverAnyDepths) {
    // Ties (many equal depths, −0 and +0), negatives (behind the eye), huge and tiny magnitudes and
    // infinities, in a list long enough for every digit of the keys to matter.
    std::mt19937 rng(3);
    const double pool[] = {0.0, -0.0, 1.0, -1.0, 1e-300, -1e-300, 1e300, -1e300, 2.5, 1e4, -7.25,
                           std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    RenderList list;
    for (uint32_t i = 0; i < 5000; ++i) {
        const double depth = i % 3 ? std::uniform_real_distribution<double>(-1e3, 1e3)(rng) : pool[rng() % std::size(pool)];
        list.opaque.push_back({nullptr, glm::dmat4(double(i)), depth, i, 1, {}});
    }
    std::vector<DrawItem> expected = list.opaque;
    std::stable_sort(expected.begin(), expected.end(), [](const DrawItem& a, const DrawItem& b) { return a.depth < b.depth; });
    list.sort();
    ASSERT_EQ(list.opaque.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i) {
        ASSERT_EQ(list.opaque[i].first, expected[i].first) << "at " << i;
        EXPECT_EQ(list.opaque[i].model[0][0], double(expected[i].first));  // the item moved whole
    }
    RenderList one;
    one.opaque.push_back({nullptr, glm::dmat4(1.0), std::nan(""), 0, 0, {}});
    one.sort();
    EXPECT_EQ(one.opaque.size(), 1u);
}

struct CullFixture : ::testing::Test {
    void SetUp() override {
        camera.look_at({0, 0, 0}, {0, 0, -1});
        projection = camera.projection_matrix(0.1, 1000);
    }
    RenderList cull(Node& root, bool culling = true) {
        RenderList list;
        CullVisitor visitor(camera, camera.view_matrix(), projection, list);
        visitor.set_frustum_culling(culling);
        root.accept(visitor);
        stats = visitor.stats();
        list.sort();
        return list;
    }
    Camera camera;
    glm::dmat4 projection;
    CullStats stats;
};

TEST_F(CullFixture, NodesOutsideTheFrustumEmitNothing) {
    auto root = std::make_shared<Group>();
    auto ahead = std::make_shared<BoxNode>(unit_box_at({0, 0, -10}), "ahead");
    auto behind = std::make_shared<BoxNode>(unit_box_at({0, 0, 10}), "behind");
    auto aside = std::make_shared<Transform>();  // its child is ahead in its own frame, aside in the world
    aside->set_matrix(glm::translate(glm::dmat4(1.0), {500, 0, 0}));
    aside->add(std::make_shared<BoxNode>(unit_box_at({0, 0, -10}), "aside"));
    root->add(ahead);
    root->add(behind);
    root->add(aside);
    RenderList list = cull(*root);
    ASSERT_EQ(list.opaque.size(), 1u);
    EXPECT_EQ(list.opaque[0].drawable, ahead.get());
    ASSERT_EQ(list.opaque[0].count, 1u);
    EXPECT_EQ(list.item_data[list.opaque[0].first], 7u);
    EXPECT_EQ(stats.nodes_culled, 2u);  // `behind` and the whole `aside` subtree
    // With culling off, all three are emitted.
    EXPECT_EQ(cull(*root, false).opaque.size(), 3u);
}

// 200 000 levels: far past what recursion over the graph survives on an 8 MB stack. Transforms at
// every level (each moves the frame by 1 along x) check that the explicit stacks keep the frames
// right; the box at the bottom must come out at the end of the chain, in world coordinates.
TEST_F(CullFixture, AChainOfTwoHundredThousandLevelsBuildsCullsFindsAndGoes) {
    constexpr int kDepth = 200000;
    auto root = std::make_shared<Group>();
    Group* bottom = root.get();
    std::weak_ptr<Node> watch;
    for (int i = 0; i < kDepth; ++i) {  // from the root down: each child is added while it has no children
        auto level = std::make_shared<Transform>();
        level->set_matrix(glm::translate(glm::dmat4(1.0), {i % 2 ? 1e-3 : -1e-3, 0, 0}));
        level->set_name("level " + std::to_string(i));
        bottom->add(level);
        bottom = level.get();
        if (i == kDepth / 2) watch = level;
    }
    auto box = std::make_shared<BoxNode>(unit_box_at({0, 0, -10}), "bottom");
    bottom->add(box);
    EXPECT_THROW(bottom->add(root), std::invalid_argument);  // the cycle check walks the whole depth

    const Box bound = root->bound();
    expect_near(bound.center(), {0, 0, -10}, 1e-6);  // the ±1e-3 shifts cancel pairwise
    EXPECT_EQ(find_node(*root, "bottom"), box.get());
    EXPECT_EQ(find_node(root, "level 199999").get(), bottom);
    EXPECT_EQ(find_node(root, static_cast<const Node*>(box.get())), box);
    RenderList list = cull(*root);
    ASSERT_EQ(list.opaque.size(), 1u);
    EXPECT_EQ(list.opaque[0].drawable, box.get());
    EXPECT_EQ(stats.nodes_visited, uint64_t(kDepth) + 2);
    // A change at the bottom reaches the root's bound.
    box->set_box(unit_box_at({0, 5, -10}));
    expect_near(root->bound().center(), {0, 5, -10}, 1e-6);

    root.reset();  // the chain goes from the top: no destructor recursion
    EXPECT_TRUE(watch.expired());
    EXPECT_TRUE(box->parents().empty());  // the node kept alive here no longer names a dead parent
}

TEST(Graph, AChainBuiltFromTheLeafUpAddsInConstantTime) {
    // Each new group takes the chain so far as its child: the child has a subtree of every level, the
    // new parent no ancestors, so the cycle check ends at once. Quadratic, this would take minutes.
    constexpr int kDepth = 200000;
    auto top = std::make_shared<Group>();
    const auto first = top;
    for (int i = 0; i < kDepth; ++i) {
        auto parent = std::make_shared<Group>();
        parent->add(top);
        top = parent;
    }
    EXPECT_THROW(first->add(top), std::invalid_argument);
    EXPECT_FALSE(top->bound().valid());  // nothing drawable in it
}

TEST_F(CullFixture, TransformsAccumulateAndHiddenNodesAreSkipped) {
    auto root = std::make_shared<Group>();
    auto outer = std::make_shared<Transform>(), inner = std::make_shared<Transform>();
    outer->set_matrix(glm::translate(glm::dmat4(1.0), {0, 0, -20}));
    inner->set_matrix(glm::scale(glm::dmat4(1.0), {2, 2, 2}));
    auto leaf = std::make_shared<BoxNode>(unit_box_at({1, 0, 0}));
    inner->add(leaf);
    outer->add(inner);
    root->add(outer);
    RenderList list = cull(*root);
    ASSERT_EQ(list.opaque.size(), 1u);
    expect_near(glm::dvec3(list.opaque[0].model * glm::dvec4(1, 0, 0, 1)), {2, 0, -20});
    EXPECT_NEAR(list.opaque[0].depth, 20.0, 1e-9);
    inner->set_visible(false);
    EXPECT_TRUE(cull(*root).opaque.empty());
}

TEST_F(CullFixture, AWhollyVisibleSubtreeIsNotTestedAgain) {
    // A group wholly inside the frustum: its children inherit an empty plane mask.
    auto root = std::make_shared<Group>();
    auto cluster = std::make_shared<Group>();
    for (int i = 0; i < 10; ++i) cluster->add(std::make_shared<BoxNode>(unit_box_at({0.1 * i, 0, -50}, 0.05)));
    root->add(cluster);
    root->add(std::make_shared<BoxNode>(unit_box_at({0, 0, 10})));  // behind: the root straddles the frustum
    RenderList list = cull(*root);
    EXPECT_EQ(list.opaque.size(), 10u);
    EXPECT_EQ(stats.nodes_visited, 13u);
    EXPECT_EQ(stats.bound_tests, 3u);  // the root, the cluster and the box behind; not the cluster's boxes
    EXPECT_EQ(stats.nodes_culled, 1u);
}

TEST_F(CullFixture, FrontToBackOrderAndLights) {
    auto root = std::make_shared<Group>();
    auto far = std::make_shared<BoxNode>(unit_box_at({0, 0, -30}), "far");
    auto near = std::make_shared<BoxNode>(unit_box_at({0, 0, -3}), "near");
    auto middle = std::make_shared<BoxNode>(unit_box_at({0, 0, -10}), "middle");
    root->add(far);
    root->add(near);
    root->add(middle);
    auto turned = std::make_shared<Transform>();
    turned->set_matrix(glm::rotate(glm::dmat4(1.0), glm::radians(90.0), {0, 1, 0}));
    auto sun = std::make_shared<DirectionalLight>();
    sun->direction = {0, 0, -2};
    sun->color = {1, 0.5f, 0.25f};
    sun->intensity = 2;
    turned->add(sun);
    root->add(turned);
    auto sky = std::make_shared<AmbientLight>();
    sky->color = {0.1f, 0.2f, 0.3f};
    root->add(sky);
    RenderList list = cull(*root);
    ASSERT_EQ(list.opaque.size(), 3u);
    EXPECT_EQ(list.opaque[0].drawable, near.get());
    EXPECT_EQ(list.opaque[1].drawable, middle.get());
    EXPECT_EQ(list.opaque[2].drawable, far.get());
    ASSERT_EQ(list.lights.size(), 1u);
    expect_near(list.lights[0].direction, {-1, 0, 0});  // −Z turned 90° about +Y
    EXPECT_FLOAT_EQ(list.lights[0].radiance.g, 1.0f);
    EXPECT_TRUE(list.has_ambient);
    EXPECT_FLOAT_EQ(list.ambient.b, 0.3f);
}

}  // namespace
}  // namespace strata

namespace strata {
namespace {

struct CountedEntry : GpuCache::Entry {
    explicit CountedEntry(int& live) : live(live) { ++live; }
    ~CountedEntry() override { --live; }
    int& live;
};

TEST(GpuCache, EntriesGoWithTheirNodesOrWhenUnused) {
    GpuCache cache;
    int live = 0;
    auto make = [&] { return std::make_unique<CountedEntry>(live); };
    auto kept = std::make_shared<Group>(), dropped = std::make_shared<Group>(), idle = std::make_shared<Group>();
    cache.get<CountedEntry>(*kept, make);
    cache.get<CountedEntry>(*dropped, make);
    cache.get<CountedEntry>(*idle, make);
    cache.get_shared<CountedEntry>(1, make);
    cache.get<CountedEntry>(*kept, make);  // the same entry again
    EXPECT_EQ(live, 4);
    dropped.reset();
    cache.end_frame(2);
    EXPECT_EQ(live, 3) << "a destroyed node's entry goes at the end of the frame";
    for (int frame = 0; frame < 3; ++frame) {
        cache.get<CountedEntry>(*kept, make);
        cache.end_frame(2);
    }
    EXPECT_EQ(live, 2) << "an entry unused for longer than the limit goes; the shared one stays";
    EXPECT_EQ(cache.size(), 1u);
}

}  // namespace
}  // namespace strata
