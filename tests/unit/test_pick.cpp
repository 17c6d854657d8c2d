// Picking: rays against Geometry under transforms (hit point, distance, normal, nearest of several,
// hidden nodes, misses), camera rays through pixel centres, the HLOD model's best-first search
// against a brute-force test of its whole drawn selection, and picks against rendered images (Mesa
// llvmpipe through EGL): wherever a pixel is not on a silhouette, the pick names the node the image
// shows there, at the depth the image holds, in the cube of the level the image shows.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "engine/scene/pick.h"
#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "tests/support/bunny_model.h"

namespace strata {
namespace {

// The solid |x| + |y| + |z| ≤ 1, its eight faces wound outward.
std::shared_ptr<Geometry> octahedron() {
    Mesh mesh;
    mesh.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    for (uint32_t x : {0u, 1u})
        for (uint32_t y : {2u, 3u})
            for (uint32_t z : {4u, 5u}) {
                const bool outward = ((x == 1) + (y == 3) + (z == 5)) % 2 == 0;  // an even number of negative axes
                mesh.indices.insert(mesh.indices.end(), {x, outward ? y : z, outward ? z : y});
            }
    auto geometry = Geometry::from_mesh(std::move(mesh));
    geometry->set_name("octahedron");
    return geometry;
}

std::shared_ptr<Transform> placed(const glm::dmat4& matrix, const NodePtr& child) {
    auto transform = std::make_shared<Transform>();
    transform->set_matrix(matrix);
    transform->add(child);
    return transform;
}

std::optional<PickHit> cast(Node& scene, const glm::dvec3& origin, const glm::dvec3& direction, const Camera& camera = {}) {
    PickVisitor visitor(camera, Ray{origin, direction});
    scene.accept(visitor);
    return visitor.nearest();
}

void expect_near(const glm::dvec3& got, const glm::dvec3& expected, double tolerance = 1e-12) {
    EXPECT_NEAR(got.x, expected.x, tolerance);
    EXPECT_NEAR(got.y, expected.y, tolerance);
    EXPECT_NEAR(got.z, expected.z, tolerance);
}

TEST(Pick, ARayMeetsAPlaneUnderATransformOnEitherFace) {
    // A floor turned to face +z, doubled and moved: the square [−1, 3] × [0, 4] at z = 3.
    auto floor = Geometry::plane({0, 0, 0}, {0, 1, 0}, 2, 2);
    Group scene;
    scene.add(placed(glm::scale(glm::rotate(glm::translate(glm::dmat4(1.0), {1, 2, 3}), glm::radians(-90.0), {1, 0, 0}),
                                glm::dvec3(2)),
                     floor));
    const auto front = cast(scene, {1.5, 2.5, 10}, {0, 0, -1});
    ASSERT_TRUE(front);
    EXPECT_EQ(front->node, floor.get());
    expect_near(front->point, {1.5, 2.5, 3});
    expect_near(front->normal, {0, 0, 1});
    EXPECT_NEAR(front->distance, 7, 1e-12);
    EXPECT_EQ(front->cube, kNoHitCube);
    // From behind, half as fast: the distance is in world units, the normal faces the ray.
    const auto back = cast(scene, {-0.5, 3.5, -10}, {0, 0, 0.5});
    ASSERT_TRUE(back);
    expect_near(back->point, {-0.5, 3.5, 3});
    expect_near(back->normal, {0, 0, -1});
    EXPECT_NEAR(back->distance, 13, 1e-12);
}

TEST(Pick, AnOctahedronUnderARotatedScaledTransform) {
    const glm::dmat4 world_from_node =
        glm::scale(glm::rotate(glm::translate(glm::dmat4(1.0), {5, -2, 1}), glm::radians(40.0), glm::normalize(glm::dvec3(1, 2, 3))),
                   glm::dvec3(3));
    auto shape = octahedron();
    Group scene;
    scene.add(placed(world_from_node, shape));
    // Aim at a known point of the face x, y, z > 0 along its own normal, from outside.
    const glm::dvec3 on_face{0.5, 0.3, 0.2};
    const glm::dvec3 face_normal = glm::normalize(glm::dmat3(world_from_node) * glm::dvec3(1, 1, 1));  // rotation · uniform scale
    const glm::dvec3 target = glm::dvec3(world_from_node * glm::dvec4(on_face, 1.0));
    const auto hit = cast(scene, target + 10.0 * face_normal, -face_normal);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->node, shape.get());
    expect_near(hit->point, target, 1e-9);
    expect_near(hit->normal, face_normal, 1e-9);
    EXPECT_NEAR(hit->distance, 10, 1e-9);
    // Along the node's −x from x = 3: the surface is at x = 1 − 0.1 − 0.05, and a node unit is 3 world units.
    const glm::dvec3 start(world_from_node * glm::dvec4(3, 0.1, 0.05, 1)), axis(glm::dmat3(world_from_node) * glm::dvec3(-1, 0, 0));
    const auto through = cast(scene, start, glm::normalize(axis));
    ASSERT_TRUE(through);
    EXPECT_NEAR(through->distance, (3 - 0.85) * 3, 1e-9);
}

TEST(Pick, TheNearestOfTwoWinsAndHiddenNodesAreIgnored) {
    auto near = octahedron(), far = octahedron();
    Group scene;
    scene.add(placed(glm::translate(glm::dmat4(1.0), {0, 0, -20}), far));  // first in traversal order
    auto near_place = placed(glm::translate(glm::dmat4(1.0), {0, 0, -10}), near);
    scene.add(near_place);
    auto hit = cast(scene, {0.1, 0.1, 0}, {0, 0, -1});
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->node, near.get());
    EXPECT_NEAR(hit->distance, 9.2, 1e-12);
    near->set_visible(false);
    hit = cast(scene, {0.1, 0.1, 0}, {0, 0, -1});
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->node, far.get());
    EXPECT_NEAR(hit->distance, 19.2, 1e-12);
    near->set_visible(true);
    near_place->set_visible(false);  // hiding a transform hides what is below it
    hit = cast(scene, {0.1, 0.1, 0}, {0, 0, -1});
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->node, far.get());
    far->set_visible(false);
    EXPECT_FALSE(cast(scene, {0.1, 0.1, 0}, {0, 0, -1}));
}

TEST(Pick, MissesFindNothing) {
    Group scene;
    scene.add(placed(glm::translate(glm::dmat4(1.0), {0, 0, -10}), octahedron()));
    EXPECT_FALSE(cast(scene, {0, 0, 0}, {0, 0, 1})) << "behind the ray";
    EXPECT_FALSE(cast(scene, {0.7, 0.7, 0}, {0, 0, -1})) << "inside the bound, outside the shape";
    EXPECT_FALSE(cast(scene, {5, 0, 0}, {0, 0, -1})) << "beside the bound";
    const Camera camera;
    PickVisitor short_ray(camera, Ray{{0, 0, 0}, {0, 0, -1}, 0, 8.5});
    scene.accept(short_ray);
    EXPECT_FALSE(short_ray.nearest()) << "ends before the surface";
    Group empty;
    EXPECT_FALSE(cast(empty, {0, 0, 0}, {0, 0, -1}));
}

// A camera ray projects onto its pixel's centre, runs from the near plane to the far plane, and has a
// unit direction.
TEST(Pick, CameraRaysPassThroughPixelCentresBetweenTheClipPlanes) {
    for (const ProjectionKind kind : {ProjectionKind::perspective, ProjectionKind::orthographic}) {
        Camera camera;
        camera.projection = kind;
        camera.width = 64;
        camera.height = 48;
        camera.ortho_height = 3;
        camera.look_at({1, 2, 3}, {-2, 0.5, -1});
        const double near = kind == ProjectionKind::orthographic ? -0.5 : 0.25, far = 40;
        const glm::dmat4 clip_from_world = camera.projection_matrix(near, far) * camera.view_matrix();
        for (const glm::dvec2 pixel : {glm::dvec2(0, 0), glm::dvec2(63.9, 47.2), glm::dvec2(20, 31)}) {
            const Ray ray = camera_ray(camera, pixel.x, pixel.y, near, far);
            EXPECT_NEAR(glm::length(ray.direction), 1, 1e-12);
            for (const auto& [t, depth] : {std::pair{ray.t_min, 1.0}, std::pair{ray.t_max, 0.0}}) {  // reversed depth
                const glm::dvec4 clip = clip_from_world * glm::dvec4(ray.at(t), 1.0);
                const glm::dvec3 ndc = glm::dvec3(clip) / clip.w;
                EXPECT_NEAR((ndc.x + 1) / 2 * camera.width, std::floor(pixel.x) + 0.5, 1e-9);
                EXPECT_NEAR((1 - ndc.y) / 2 * camera.height, std::floor(pixel.y) + 0.5, 1e-9);
                EXPECT_NEAR(ndc.z, depth, 1e-9);
            }
        }
    }
}

class PickHlod : public ::testing::Test {
protected:
    void SetUp() override {
        if (test::bunny_hlod().empty()) GTEST_SKIP() << "data/bunny.off missing: run scripts/setup.sh";
    }
};

// The best-first search finds what testing every triangle of the drawn selection finds (the same
// triangle, in the same cube), from views that mix levels and catch vertices mid-morph.
TEST_F(PickHlod, TheSearchAlongTheRayFindsWhatTheWholeSelectionGives) {
    auto model = HlodModel::load(test::bunny_hlod());
    model->set_pixel_error(1.0);
    const glm::dmat4 world_from_node = glm::scale(
        glm::rotate(glm::translate(glm::dmat4(1.0), {100.5, -3, 7}), glm::radians(-25.0), glm::normalize(glm::dvec3(2, 1, -1))),
        glm::dvec3(4));
    Group scene;
    scene.add(placed(world_from_node, model));
    const Box bound = scene.bound();
    size_t hits = 0, checked = 0, moved_by_morph = 0;
    std::set<uint32_t> levels;
    for (const ProjectionKind kind : {ProjectionKind::perspective, ProjectionKind::orthographic})
        for (const double distance : {0.4, 1.5}) {
            Camera camera;
            camera.projection = kind;
            camera.width = 160;
            camera.height = 120;
            camera.look_at(bound.center() + distance * bound.radius() * glm::normalize(glm::dvec3(1, 0.5, 2)), bound.center());
            camera.ortho_height = distance * bound.radius();
            const auto [near, far] = camera.clip_planes_for(bound);
            const glm::dvec3 eye_world(glm::inverse(camera.view_matrix())[3]);
            const HlodModel::LatticeAnchor anchor = model->anchor_for(world_from_node, eye_world);
            const glm::dvec3 local_eye(glm::inverse(world_from_node) * glm::dvec4(eye_world, 1.0));
            HlodView view{local_eye - model->origin(), model->kappas_for(camera)};
            if (kind == ProjectionKind::orthographic) view.fixed_level = model->orthographic_level(camera);
            std::vector<uint32_t> selection;
            model->select(view, selection);
            // Every triangle of the selection, morphed (as drawn in perspective) or not.
            auto brute_force = [&](const Ray& lattice_ray, bool morphed) {
                std::optional<SurfaceHit> nearest;
                std::vector<glm::vec3> positions;
                for (const uint32_t c : selection) {
                    const HlodCube& cube = model->cubes()[c];
                    model->morphed_positions(c, anchor, *model->kappas_for(camera), positions);
                    if (!morphed)
                        for (uint32_t v = 0; v < positions.size(); ++v)
                            positions[v] = model->anchored_position(cube.node.level, model->lattice_steps(cube, v), anchor);
                    Ray anchored_ray = lattice_ray;  // the positions are drawn from the anchor
                    anchored_ray.origin -= anchor.origin;
                    const auto hit = nearest_triangle(anchored_ray, cube.data->indices, [&](uint32_t v) { return glm::dvec3(positions[v]); });
                    if (hit && (!nearest || hit->t < nearest->t)) nearest = SurfaceHit{hit->t, hit->normal, c};
                }
                return nearest;
            };
            for (int y = 3; y < camera.height; y += 9)
                for (int x = 5; x < camera.width; x += 9) {
                    const Ray world_ray = camera_ray(camera, x, y, near, far);
                    const Ray lattice_ray = world_ray.transformed(glm::inverse(world_from_node * model->lattice_to_node()));
                    const std::optional<SurfaceHit> expected = brute_force(lattice_ray, kind == ProjectionKind::perspective);
                    PickVisitor visitor(camera, world_ray);
                    scene.accept(visitor);
                    const auto& got = visitor.nearest();
                    ++checked;
                    ASSERT_EQ(got.has_value(), expected.has_value()) << "pixel " << x << ", " << y;
                    if (!got) continue;
                    ++hits;
                    // The lattice ray here is derived in one step, the pick's in two: t agrees to rounding.
                    EXPECT_NEAR(got->distance, expected->t, 1e-9 * std::abs(expected->t));
                    EXPECT_EQ(got->cube, expected->cube);
                    levels.insert(model->cubes()[got->cube].node.level);
                    if (kind == ProjectionKind::perspective) {
                        const std::optional<SurfaceHit> unmorphed = brute_force(lattice_ray, false);
                        moved_by_morph += !unmorphed || std::abs(unmorphed->t - expected->t) > 1e-6 * std::abs(expected->t);
                    }
                }
        }
    EXPECT_GT(hits, checked / 4);
    EXPECT_GE(levels.size(), 3u) << "the views should pick from several levels";
    EXPECT_GT(moved_by_morph, 10u) << "the views should catch surfaces mid-morph";
}

// A pick says when what it hit stands in for data not yet resident (hit.provisional): with the
// finest level missing, every pixel whose full-detail pick lands on that level is provisional, and a
// pick that is not provisional hits the very cube the full-detail pick hits. A model with every cube
// resident gives no provisional pick.
TEST_F(PickHlod, HitsOnStandInsAreProvisional) {
    auto model = HlodModel::load(test::bunny_hlod());
    model->set_pixel_error(1.0);
    Group scene;
    scene.add(model);
    const Box bound = scene.bound();
    Camera camera;
    camera.width = 160;
    camera.height = 120;
    camera.look_at(bound.center() + 1.2 * bound.radius() * glm::normalize(glm::dvec3(1, 0.5, 2)), bound.center());
    std::vector<std::optional<PickHit>> full;
    for (int y = 3; y < camera.height; y += 6)
        for (int x = 5; x < camera.width; x += 6) full.push_back(pick(scene, camera, x, y));
    const uint32_t finest = model->header().max_level;
    std::vector<uint8_t> resident(model->cubes().size());
    for (uint32_t c = 0; c < resident.size(); ++c) resident[c] = model->cubes()[c].node.level < finest;
    model->set_residency(resident);
    size_t k = 0, provisional = 0, settled = 0, finest_hits = 0;
    for (int y = 3; y < camera.height; y += 6)
        for (int x = 5; x < camera.width; x += 6, ++k) {
            const std::optional<PickHit> partial = pick(scene, camera, x, y);
            if (full[k]) {
                EXPECT_FALSE(full[k]->provisional) << "every cube resident, at pixel " << x << ", " << y;
            }
            if (!full[k] || !partial) continue;
            if (model->cubes()[full[k]->cube].node.level == finest) {
                ++finest_hits;
                EXPECT_TRUE(partial->provisional) << "pixel " << x << ", " << y;
            }
            if (partial->provisional) ++provisional;
            else {
                ++settled;
                EXPECT_EQ(partial->cube, full[k]->cube) << "pixel " << x << ", " << y;
            }
        }
    EXPECT_GT(finest_hits, 10u) << "the view should draw the finest level in places";
    EXPECT_GT(provisional, 10u);
    EXPECT_GT(settled, 10u) << "the view should draw coarser levels in places";
}

// ---- against rendered images ---------------------------------------------------------------------

class PickRender : public PickHlod {
protected:
    static void SetUpTestSuite() { context_ = gl::create_headless_context(); }
    static void TearDownTestSuite() { context_.reset(); }

    struct Agreement {
        size_t compared = 0, hits = 0;
        size_t wrong_node = 0, wrong_depth = 0, wrong_level = 0;
        double worst_depth_error = 0;  // relative
        std::set<int> levels;          // HLOD levels compared
    };

    // Renders `scene` (one sample per pixel: the ids and depths of the surface at each pixel centre)
    // and picks every `step`-th pixel whose 3×3 neighbourhood shows one node.
    static Agreement compare(Node& scene, const Camera& camera, int step) {
        gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1, .level = true, .node_id = true});
        Renderer renderer;
        renderer.render(scene, camera, target);
        const Image image = renderer.read_image(target);
        auto at = [&](int x, int y) { return size_t(y) * image.width + size_t(x); };
        auto uniform = [&](const auto& plane, int x, int y) {
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int nx = std::clamp(x + dx, 0, image.width - 1), ny = std::clamp(y + dy, 0, image.height - 1);
                    if (plane[at(nx, ny)] != plane[at(x, y)]) return false;
                }
            return true;
        };
        Agreement a;
        for (int y = 0; y < image.height; y += step)
            for (int x = 0; x < image.width; x += step) {
                if (!uniform(image.node_id, x, y)) continue;
                ++a.compared;
                const size_t p = at(x, y);
                const std::optional<PickHit> hit = pick(scene, camera, x, y);
                if ((hit ? hit->node->id() : 0u) != image.node_id[p]) {
                    ++a.wrong_node;
                    continue;
                }
                if (!hit) continue;
                ++a.hits;
                const double depth = glm::dot(hit->point - camera.position, camera.forward());
                const double error = std::abs(depth - image.depth[p]) / image.depth[p];
                a.worst_depth_error = std::max(a.worst_depth_error, error);
                a.wrong_depth += error > 1e-4;
                if (hit->cube == kNoHitCube || !uniform(image.level, x, y)) continue;
                const auto& model = dynamic_cast<const HlodModel&>(*hit->node);
                const int level = int(model.cubes()[hit->cube].node.level);
                a.levels.insert(level);
                a.wrong_level += float(level) != image.level[p];
            }
        return a;
    }

    static void expect_agreement(const Agreement& a, size_t min_hits) {
        EXPECT_GE(a.hits, min_hits) << "of " << a.compared << " pixels compared";
        EXPECT_EQ(a.wrong_node, 0u) << "of " << a.compared << " pixels compared";
        EXPECT_EQ(a.wrong_depth, 0u) << "of " << a.hits << " hits; worst relative depth error " << a.worst_depth_error;
        EXPECT_EQ(a.wrong_level, 0u) << "of " << a.hits << " hits";
    }

    static inline std::unique_ptr<gl::Context> context_;
};

// Two bunnies (one turned and enlarged, one moved) on a floor, seen from close up: levels mix.
struct BunniesOnAFloor {
    Group scene;
    std::shared_ptr<HlodModel> turned = HlodModel::load(test::bunny_hlod()), moved = HlodModel::load(test::bunny_hlod());
    std::shared_ptr<Geometry> floor;
    Camera camera;

    BunniesOnAFloor() {
        const Box box = turned->bound();
        const double size = turned->header().root_size;
        // Coarse enough that the view, from close up to a few bunny lengths away, mixes levels.
        turned->set_pixel_error(3.0);
        moved->set_pixel_error(3.0);
        const glm::dmat4 stand = glm::translate(glm::dmat4(1.0), glm::dvec3(-box.center().x, -box.lo.y, -box.center().z));
        scene.add(placed(glm::scale(glm::rotate(glm::dmat4(1.0), glm::radians(70.0), glm::normalize(glm::dvec3(0.2, 1, 0.1))),
                                    glm::dvec3(1.6)) * stand,
                         turned));
        scene.add(placed(glm::translate(glm::dmat4(1.0), {1.3 * size, 0, -0.8 * size}) * stand, moved));
        floor = Geometry::plane({0, 0, 0}, {0, 1, 0}, 6 * size, 6 * size);
        scene.add(floor);
        camera.width = 240;
        camera.height = 180;
        camera.look_at(glm::dvec3(0.5, 0.9, 1.1) * size, glm::dvec3(0.3, 0.5, -0.2) * size);
    }
};

TEST_F(PickRender, PerspectivePicksMatchTheRenderedIdsDepthsAndLevels) {
    BunniesOnAFloor bunnies;
    const Agreement a = compare(bunnies.scene, bunnies.camera, 3);
    expect_agreement(a, 2000);
    EXPECT_GE(a.levels.size(), 2u) << "the view should mix levels";
}

TEST_F(PickRender, OrthographicPicksMatchTheRenderedIdsDepthsAndLevels) {
    BunniesOnAFloor bunnies;
    bunnies.camera.projection = ProjectionKind::orthographic;
    bunnies.turned->set_pixel_error(1.0);
    bunnies.moved->set_pixel_error(1.0);
    bunnies.camera.look_at(glm::dvec3(2, 1.5, 3) * bunnies.turned->header().root_size, glm::dvec3(0));
    Box bunnies_box = bunnies.scene.child(0)->bound();
    bunnies_box.expand(bunnies.scene.child(1)->bound());
    bunnies.camera.frame(bunnies_box);
    bunnies.camera.ortho_height /= 2;  // close enough for a level finer than 0
    const Agreement a = compare(bunnies.scene, bunnies.camera, 3);
    expect_agreement(a, 2000);
}

// With the morph off the drawn surface is another one, and the pick follows it.
TEST_F(PickRender, WithTheMorphOffPicksMatchTheUnmorphedImage) {
    BunniesOnAFloor bunnies;
    bunnies.turned->set_morph(false);
    bunnies.moved->set_morph(false);
    expect_agreement(compare(bunnies.scene, bunnies.camera, 3), 2000);
}

}  // namespace
}  // namespace strata
