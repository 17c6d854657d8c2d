// The HLOD node's selection and its CPU morph twin (DESIGN.md §3, §6) on the real bunny: the drawn
// set is watertight from any view with the morph on and cracked without it (the crack check), a
// cube's children at the switch distance draw exactly its triangles (the pop check, Lemma 2),
// neighbouring drawn cubes differ by at most one level (Lemma 1), and culling drops cubes out of view.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <set>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/scene/camera.h"
#include "engine/scene/cull_visitor.h"
#include "nodes/hlod_model.h"
#include "preprocess/hlod_builder.h"
#include "tests/support/bunny_model.h"

namespace strata {
namespace {

using Position = std::array<uint32_t, 3>;  // a morphed position's float bits: welds exactly

Position bits(const glm::vec3& p) {
    Position out;
    std::memcpy(out.data(), &p, sizeof out);
    return out;
}

class HlodSelection : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        if (!test::bunny_hlod().empty()) model_ = HlodModel::load(test::bunny_hlod());
    }
    static void TearDownTestSuite() { model_.reset(); }
    void SetUp() override {
        if (!model_) GTEST_SKIP() << "data/bunny.off missing: run scripts/setup.sh";
    }

    // The drawn triangles of a view as morphed positions, degenerate ones dropped.
    std::vector<std::array<Position, 3>> drawn(const std::vector<uint32_t>& cubes, const glm::dvec3& eye, double kappa0) {
        std::vector<std::array<Position, 3>> triangles;
        std::vector<glm::vec3> positions;
        for (uint32_t c : cubes) {
            model_->morphed_positions(c, glm::vec3(eye), float(kappa0), positions);
            const auto& indices = model_->cubes()[c].data.indices;
            for (size_t t = 0; t < indices.size(); t += 3) {
                std::array<Position, 3> tri{bits(positions[indices[t]]), bits(positions[indices[t + 1]]),
                                            bits(positions[indices[t + 2]])};
                if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
                triangles.push_back(tri);
            }
        }
        return triangles;
    }
    // Edges (undirected, welded by position) used an odd number of times: cracks in a closed surface.
    static size_t odd_edges(const std::vector<std::array<Position, 3>>& triangles) {
        std::vector<std::pair<Position, Position>> edges;
        for (const auto& t : triangles)
            for (int e = 0; e < 3; ++e) edges.push_back(std::minmax(t[e], t[(e + 1) % 3]));
        std::sort(edges.begin(), edges.end());
        size_t odd = 0;
        for (size_t i = 0, j; i < edges.size(); i = j) {
            for (j = i; j < edges.size() && edges[j] == edges[i]; ++j) {
            }
            odd += (j - i) % 2;
        }
        return odd;
    }
    uint32_t level_spread(const std::vector<uint32_t>& cubes) const {
        uint32_t lo = ~0u, hi = 0;
        for (uint32_t c : cubes) lo = std::min(lo, model_->cubes()[c].node.level), hi = std::max(hi, model_->cubes()[c].node.level);
        return hi - lo;
    }
    // Random eyes: half around the model, half inside its bounds just off the surface.
    std::vector<glm::dvec3> eyes(int count) const {
        std::mt19937 rng(2026);
        std::uniform_real_distribution<double> unit(-1, 1), share(0, 1);
        const double size = model_->header().root_size;
        const glm::dvec3 centre = 0.5 * glm::dvec3(size);
        std::vector<glm::dvec3> out;
        const auto& finest = model_->cubes();
        for (int i = 0; i < count; ++i) {
            if (i % 2 == 0) {
                glm::dvec3 dir{unit(rng), unit(rng), unit(rng)};
                out.push_back(centre + glm::normalize(dir) * size * (0.3 + 1.2 * share(rng)));
                continue;
            }
            const HlodCube* cube;
            do cube = &finest[size_t(share(rng) * finest.size()) % finest.size()];
            while (cube->node.level != model_->header().max_level || cube->data.vertex_count() == 0);
            const glm::vec3 p = model_->vertex_position(*cube, uint32_t(share(rng) * cube->data.vertex_count()) % cube->data.vertex_count());
            out.push_back(glm::dvec3(p) + glm::dvec3(unit(rng), unit(rng), unit(rng)) * (0.01 * size));
        }
        return out;
    }

    static inline std::shared_ptr<HlodModel> model_;
};

TEST_F(HlodSelection, TheModelLoadsWithItsOctree) {
    const HlodHeader& h = model_->header();
    EXPECT_EQ(h.max_level, 3u);
    EXPECT_EQ(model_->cubes()[model_->root()].node.level, 0u);
    size_t linked = 0;
    for (const HlodCube& c : model_->cubes())
        for (uint32_t child : c.children) linked += child != kNoCube;
    EXPECT_EQ(linked, model_->cubes().size() - 1);  // every cube but the root has exactly one parent
    EXPECT_TRUE(model_->bound().valid());
    EXPECT_GE(model_->min_kappa0(), 1.0 + 3.0 * h.sigma0);
}

TEST_F(HlodSelection, WatertightFromEveryViewWithTheMorphAndCrackedWithout) {
    const double kappa0 = std::max(2.0, model_->min_kappa0());
    std::vector<uint32_t> cubes;
    int mixed_views = 0, cracked_without_morph = 0;
    for (const glm::dvec3& eye : eyes(102)) {
        model_->select({eye, kappa0}, cubes);
        ASSERT_FALSE(cubes.empty());
        model_->set_morph(true);
        ASSERT_EQ(odd_edges(drawn(cubes, eye, kappa0)), 0u) << "crack seen from " << eye.x << " " << eye.y << " " << eye.z;
        if (level_spread(cubes) == 0) continue;
        ++mixed_views;
        model_->set_morph(false);
        cracked_without_morph += odd_edges(drawn(cubes, eye, kappa0)) > 0;
    }
    model_->set_morph(true);
    // The check can fail: views that mix levels exist and, without the morph, show cracks.
    EXPECT_GT(mixed_views, 50);
    EXPECT_GT(cracked_without_morph, mixed_views / 2);
}

TEST_F(HlodSelection, NeighbouringCubesDifferByAtMostOneLevel) {
    const double kappa0 = std::max(2.0, model_->min_kappa0());
    std::vector<uint32_t> cubes;
    for (const glm::dvec3& eye : eyes(40)) {
        model_->select({eye, kappa0}, cubes);
        for (uint32_t a : cubes)
            for (uint32_t b : cubes) {
                const Box ca = model_->cell(model_->cubes()[a].node), cb = model_->cell(model_->cubes()[b].node);
                const bool touch = glm::all(glm::lessThanEqual(ca.lo, cb.hi)) && glm::all(glm::lessThanEqual(cb.lo, ca.hi));
                if (!touch) continue;
                const int la = int(model_->cubes()[a].node.level), lb = int(model_->cubes()[b].node.level);
                EXPECT_LE(std::abs(la - lb), 1);
            }
    }
}

// Lemma 2: with the eye where a cube just stops being suitable, its children's morphed triangles are
// exactly its own (each child vertex at its parent, the parent's vertices unmoved): no pop.
TEST_F(HlodSelection, ChildrenAtTheSwitchDrawTheParentsTriangles) {
    const double kappa0 = std::max(2.0, model_->min_kappa0());
    int checked = 0;
    for (uint32_t c = 0; c < model_->cubes().size() && checked < 20; ++c) {
        const HlodCube& cube = model_->cubes()[c];
        if (cube.node.level == model_->header().max_level || cube.node.level == 0) continue;
        const Box cell = model_->cell(cube.node);
        const double s = model_->header().cube_size(cube.node.level);
        // Straight out from the cell's top face, at the switch distance: just outside it the cube is
        // drawn, just inside its children are.
        const glm::dvec3 top{cell.center().x, cell.center().y, cell.hi.z};
        const double switch_distance = kappa0 * s;
        const glm::dvec3 before = top + glm::dvec3(0, 0, switch_distance * (1 + 1e-6));
        const glm::dvec3 after = top + glm::dvec3(0, 0, switch_distance * (1 - 1e-6));
        std::vector<uint32_t> parent{c}, children;
        for (uint32_t child : cube.children)
            if (child != kNoCube) children.push_back(child);
        auto canonical = [](std::vector<std::array<Position, 3>> tris) {
            for (auto& t : tris)
                while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};  // cyclic: orientation kept
            std::sort(tris.begin(), tris.end());
            return tris;
        };
        const auto drawn_before = canonical(drawn(parent, before, kappa0));
        const auto drawn_after = canonical(drawn(children, after, kappa0));
        EXPECT_EQ(drawn_before, drawn_after) << describe_cube(cube.node);
        ++checked;
    }
    EXPECT_EQ(checked, 20);
}

TEST_F(HlodSelection, CubesOutsideTheFrustumAreNotSelected) {
    const HlodHeader& h = model_->header();
    const glm::dvec3 centre = 0.5 * glm::dvec3(h.root_size);
    Camera camera;
    camera.look_at(centre + glm::dvec3(0, 0, 1.2 * h.root_size), centre + glm::dvec3(0, 0, 2 * h.root_size));  // looking away
    const glm::dmat4 clip = camera.projection_matrix(0.001, 10 * h.root_size) * camera.view_matrix();
    const Frustum frustum = Frustum::from_matrix(clip);
    std::vector<uint32_t> cubes;
    model_->select({camera.position, 2.5, &frustum}, cubes);
    EXPECT_TRUE(cubes.empty());
    // Looking at the centre from close by: fewer cubes than without culling, and every one in view.
    camera.look_at(centre + glm::dvec3(0.1, 0.05, 0.3) * h.root_size, centre);
    const Frustum facing = Frustum::from_matrix(camera.projection_matrix(0.001, 10 * h.root_size) * camera.view_matrix());
    std::vector<uint32_t> all;
    model_->select({camera.position, 2.5}, all);
    model_->select({camera.position, 2.5, &facing}, cubes);
    EXPECT_FALSE(cubes.empty());
    EXPECT_LT(cubes.size(), all.size());
    for (uint32_t c : cubes) EXPECT_NE(std::find(all.begin(), all.end(), c), all.end());
}

TEST_F(HlodSelection, TheNodeSelectsInItsOwnFrameUnderATransform) {
    // Two copies of the model under different transforms, the eye close to one of them: each copy's
    // cubes are the selection for the eye carried into its own frame, and they differ.
    auto root = std::make_shared<Group>();
    auto near = std::make_shared<Transform>(), far = std::make_shared<Transform>();
    const double size = model_->header().root_size;
    near->set_matrix(glm::scale(glm::rotate(glm::dmat4(1.0), glm::radians(40.0), {0, 1, 0}), glm::dvec3(1.5)));
    far->set_matrix(glm::translate(glm::dmat4(1.0), glm::dvec3(3 * size, 0, 0)));
    near->add(model_);
    far->add(model_);
    root->add(near);
    root->add(far);
    Camera camera;
    const glm::dvec3 centre = near->bound().center();
    camera.look_at(centre + glm::dvec3(0.1, 0.2, 0.9) * size, centre + glm::dvec3(size, 0, 0));
    const double kappa0 = model_->kappa0_for(camera.width, camera.tan_half_fov_x());
    auto [near_plane, far_plane] = camera.clip_planes_for(root->bound());
    RenderList list;
    CullVisitor cull(camera, camera.view_matrix(), camera.projection_matrix(near_plane, far_plane), list);
    cull.set_frustum_culling(false);
    root->accept(cull);
    ASSERT_EQ(list.opaque.size(), 2u);
    std::vector<std::vector<uint32_t>> drawn;
    for (const DrawItem& item : list.opaque) {
        std::vector<uint32_t> cubes(list.item_data.begin() + item.first, list.item_data.begin() + item.first + item.count);
        const glm::dvec3 eye = glm::dvec3(glm::inverse(item.model) * glm::dvec4(camera.position, 1.0)) - model_->origin();
        std::vector<uint32_t> expected;
        model_->select({eye, kappa0}, expected);
        EXPECT_EQ(cubes, expected);
        drawn.push_back(cubes);
    }
    EXPECT_NE(drawn[0], drawn[1]);
    EXPECT_GT(level_spread(drawn[0]), 0u) << "the near copy, seen from close by, mixes levels";
    near->remove(model_.get());
    far->remove(model_.get());
}

// The promise of --pixel-error P (DESIGN.md §3, §8), checked from the geometry, not from Eq. 4.5: with
// κ0 = kappa0_for(width, tan) every drawn cube's level error ε_l (the largest error stored for a cube of
// its level), seen from the eye at the nearest point the cube can draw anything (its cull box), spans
// at most P pixels; and where a vertex morphs toward its parent, the parent level's error does too at
// that vertex's distance. Eyes from just off the surface to far away, so every level gets drawn.
TEST_F(HlodSelection, PixelErrorBoundsTheProjectedErrorOfEveryDrawnCube) {
    const HlodHeader& h = model_->header();
    const int width = 1920;
    const double tan_half_fov = std::tan(glm::radians(30.0));
    const double pixels_per_unit_at_unit_distance = width / (2 * tan_half_fov);
    std::vector<double> level_error(h.max_level + 1, 0.0);
    for (const HlodCube& c : model_->cubes()) level_error[c.node.level] = std::max(level_error[c.node.level], double(c.node.error));
    ASSERT_GT(level_error[0], 0.0);

    std::vector<glm::dvec3> views = eyes(40);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(-1, 1), exponent(-1, std::log(80.0));
    for (int i = 0; i < 60; ++i) {
        const glm::dvec3 dir = glm::normalize(glm::dvec3{unit(rng), unit(rng), unit(rng)});
        views.push_back(0.5 * glm::dvec3(h.root_size) + dir * h.root_size * std::exp(exponent(rng)));
    }
    auto distance_to = [](const glm::dvec3& p, const Box& box) {
        return glm::length(glm::max(glm::dvec3(0.0), glm::max(box.lo - p, p - box.hi)));
    };

    std::vector<uint64_t> triangles_per_target;
    std::set<uint32_t> levels_drawn;
    for (const double pixels : {1.0, 4.0, 16.0}) {
        model_->set_pixel_error(pixels);
        const double kappa0 = model_->kappa0_for(width, tan_half_fov);
        uint64_t triangles = 0;
        double worst = 0;
        std::vector<uint32_t> cubes;
        std::vector<glm::vec3> morphed;
        for (const glm::dvec3& eye : views) {
            model_->select({eye, kappa0}, cubes);
            for (uint32_t c : cubes) {
                const HlodCube& cube = model_->cubes()[c];
                const uint32_t level = cube.node.level;
                levels_drawn.insert(level);
                triangles += cube.data.triangle_count();
                const double distance = distance_to(eye, model_->cull_box(cube.node));
                const double projected = distance > 0 ? level_error[level] * pixels_per_unit_at_unit_distance / distance
                                                      : (level_error[level] > 0 ? INFINITY : 0.0);
                // The full resolution, drawn as close as the eye likes, is as exact as it gets: its
                // bound (the lattice's rounding) is outside the promise.
                if (level < h.max_level) {
                    EXPECT_LE(projected, pixels) << describe_cube(cube.node) << " for P " << pixels << " from "
                                                 << eye.x << " " << eye.y << " " << eye.z;
                    worst = std::max(worst, projected);
                }
                if (level == 0) continue;
                model_->morphed_positions(c, glm::vec3(eye), float(kappa0), morphed);
                double nearest_morphing = INFINITY;
                for (uint32_t v = 0; v < cube.data.vertex_count(); ++v) {
                    const glm::vec3 own = model_->vertex_position(cube, v);
                    if (morphed[v] != own) nearest_morphing = std::min(nearest_morphing, glm::length(eye - glm::dvec3(own)));
                }
                EXPECT_LE(level_error[level - 1] * pixels_per_unit_at_unit_distance / nearest_morphing, pixels)
                    << describe_cube(cube.node) << " morphing toward its parent, P " << pixels;
            }
        }
        // The bound is not met by drawing everything finer than needed: some cube comes near it.
        EXPECT_GT(worst, pixels / 4) << "P " << pixels;
        triangles_per_target.push_back(triangles);
    }
    EXPECT_EQ(levels_drawn.size(), h.max_level + 1u);
    // A coarser target draws fewer triangles.
    EXPECT_GT(triangles_per_target[0], triangles_per_target[1]);
    EXPECT_GT(triangles_per_target[1], triangles_per_target[2]);

    // However coarse the target, κ0 stays where the morph works: κ0 ≥ 1 + 3σ0 + 0.25 (DESIGN.md §3).
    const double morph_minimum = 1.0 + 3.0 * double(h.sigma0) + 0.25;
    model_->set_pixel_error(1e6);
    EXPECT_DOUBLE_EQ(model_->kappa0_for(width, tan_half_fov), morph_minimum);
    model_->set_kappa0(0.5);
    EXPECT_DOUBLE_EQ(model_->kappa0(), morph_minimum);
    EXPECT_DOUBLE_EQ(model_->kappa0_for(width, tan_half_fov), morph_minimum);
    EXPECT_THROW(model_->set_pixel_error(-1), std::invalid_argument);
    model_->set_kappa0(2.0);
}

TEST(HlodLoad, ACorruptFileIsRefusedNamingIt) {
    test::TempDir dir;
    BuildSettings settings;
    settings.levels = 2;
    build_hlod(test::icosphere(3), dir / "s.hlod", settings, "s");
    {  // flip a byte in the first payload
        std::FILE* f = std::fopen((dir / "s.hlod").c_str(), "r+b");
        ASSERT_NE(f, nullptr);
        std::fseek(f, 200, SEEK_SET);
        const int byte = std::fgetc(f);
        std::fseek(f, 200, SEEK_SET);
        std::fputc(byte ^ 0x55, f);
        std::fclose(f);
    }
    try {
        HlodModel::load(dir / "s.hlod");
        FAIL() << "a corrupt file loaded";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("s.hlod"), std::string::npos) << e.what();
    }
    EXPECT_THROW(HlodModel::load(dir / "missing.hlod"), std::runtime_error);
}

}  // namespace
}  // namespace strata
