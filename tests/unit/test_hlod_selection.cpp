// The HLOD node's selection and its CPU morph twin (DESIGN.md §3, §6) on the real bunny: the drawn
// set is watertight from any view with the morph on and cracked without it (the crack check), a
// cube's children at the switch distance draw exactly its triangles (the pop check, Lemma 2),
// neighbouring drawn cubes differ by at most one level (Lemma 1), and culling drops cubes out of view.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <random>
#include <set>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/scene/camera.h"
#include "engine/scene/cull_visitor.h"
#include "nodes/hlod_model.h"
#include "preprocess/hlod_builder.h"
#include "tests/support/bunny_model.h"
#include "tests/support/crack_check.h"
#include "tests/support/dem_grid.h"

namespace strata {
namespace {

using test::Position;
using test::drawn_triangles;
using test::odd_edge_list;
using test::odd_edges;

// How many separate loops the odd edges of an open surface form: its outline is one, and each crack
// away from the outline is another.
size_t boundary_loops(const std::vector<std::array<Position, 3>>& triangles) {
    const auto odd = odd_edge_list(triangles);
    std::map<Position, Position> parent;
    auto root = [&](Position p) {
        while (parent.at(p) != p) p = parent[p] = parent[parent[p]];
        return p;
    };
    for (const auto& [a, b] : odd) parent.emplace(a, a), parent.emplace(b, b);
    for (const auto& [a, b] : odd) parent[root(a)] = root(b);
    size_t loops = 0;
    for (const auto& [p, up] : parent) loops += p == up;
    return loops;
}

uint32_t level_spread(const HlodModel& model, const std::vector<uint32_t>& cubes) {
    uint32_t lo = ~0u, hi = 0;
    for (uint32_t c : cubes) lo = std::min(lo, model.cubes()[c].node.level), hi = std::max(hi, model.cubes()[c].node.level);
    return hi - lo;
}

// The largest κ of a level's cubes: how far out that level still switches.
double largest_kappa(const HlodModel& model, const CubeKappas& kappa, uint32_t level) {
    double largest = 0;
    for (uint32_t c = 0; c < model.cubes().size(); ++c)
        if (model.cubes()[c].node.level == level) largest = std::max(largest, kappa[c]);
    return largest;
}

// The crack check: from every eye the drawn cut has no crack (`cracks` of its triangles is 0), and it can
// fail: at least `min_mixed` views mix levels and, without the morph, most of them show cracks.
template <class Cracks>
void expect_watertight(HlodModel& model, const Kappas& kappa, const std::vector<glm::dvec3>& eyes, int min_mixed,
                       Cracks&& cracks) {
    std::vector<uint32_t> cubes;
    int mixed_views = 0, cracked_without_morph = 0;
    for (const glm::dvec3& eye : eyes) {
        Kappas morph;  // with the band ends of the cubes the view caps, while cubes are missing
        model.select({eye, kappa}, cubes, &morph);
        ASSERT_FALSE(cubes.empty());
        model.set_morph(true);
        ASSERT_EQ(cracks(drawn_triangles(model, cubes, eye, *morph)), 0u)
            << "crack seen from " << eye.x << " " << eye.y << " " << eye.z << ", κ_root " << (*kappa)[model.root()];
        if (level_spread(model, cubes) == 0) continue;
        ++mixed_views;
        model.set_morph(false);
        cracked_without_morph += cracks(drawn_triangles(model, cubes, eye, *morph)) > 0;
        model.set_morph(true);
    }
    EXPECT_GT(mixed_views, min_mixed) << "κ_root " << (*kappa)[model.root()];
    EXPECT_GT(cracked_without_morph, mixed_views / 2) << "κ_root " << (*kappa)[model.root()];
}

// Lemma 2 for `checked` cubes: with the eye where a cube just stops being suitable, its children's
// morphed triangles are exactly its own (each child vertex at its parent, the parent's vertices
// unmoved): no pop.
void expect_no_pop(const HlodModel& model, const CubeKappas& kappa, int wanted) {
    int checked = 0;
    for (uint32_t c = 0; c < model.cubes().size() && checked < wanted; ++c) {
        const HlodCube& cube = model.cubes()[c];
        if (cube.node.level == model.header().max_level || cube.node.level == 0) continue;
        const Box cell = model.cell(cube.node);
        const double s = model.header().cube_size(cube.node.level);
        // Straight out from the cell's top face, at the switch distance: just outside it the cube is
        // drawn, just inside its children are.
        const glm::dvec3 top{cell.center().x, cell.center().y, cell.hi.z};
        const double switch_distance = kappa[c] * s;
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
        // Both measured from one point, so that their bits can be compared.
        const auto drawn_before = canonical(drawn_triangles(model, parent, before, kappa, before));
        const auto drawn_after = canonical(drawn_triangles(model, children, after, kappa, before));
        EXPECT_EQ(drawn_before, drawn_after) << describe_cube(cube.node) << ", κ " << kappa[c];
        ++checked;
    }
    EXPECT_EQ(checked, wanted);
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

    // The κ the checks run with: one κ0 for every cube, and per cube as pixel errors set them for
    // a 1920-pixel-wide 60° view (nodes/README.md, "Selection").
    static std::vector<Kappas> kappa_sets() {
        std::vector<Kappas> sets{model_->uniform_kappas(std::max(2.0, model_->min_kappa0()))};
        Camera camera;
        camera.width = 1920, camera.height = 1080, camera.fov_y_degrees = 60;
        for (double pixels : {16.0, 64.0}) {
            model_->set_pixel_error(pixels);
            sets.push_back(model_->kappas_for(camera));
        }
        model_->set_kappa0(2.0);
        return sets;
    }
    // Random eyes: half around the model, half inside its bounds just off the surface.
    // `reach` scales how far out the eyes around the model go (for larger κ, which switch farther).
    std::vector<glm::dvec3> eyes(int count, double reach = 1) const {
        std::mt19937 rng(2026);
        std::uniform_real_distribution<double> unit(-1, 1), share(0, 1);
        const double size = model_->header().root_size;
        const glm::dvec3 centre = 0.5 * glm::dvec3(size);
        std::vector<glm::dvec3> out;
        const auto& finest = model_->cubes();
        for (int i = 0; i < count; ++i) {
            if (i % 2 == 0) {
                glm::dvec3 dir{unit(rng), unit(rng), unit(rng)};
                out.push_back(centre + glm::normalize(dir) * size * (0.3 + 1.2 * reach * share(rng)));
                continue;
            }
            const HlodCube* cube;
            do cube = &finest[size_t(share(rng) * finest.size()) % finest.size()];
            while (cube->node.level != model_->header().max_level || cube->data->vertex_count() == 0);
            const glm::vec3 p = model_->vertex_position(*cube, uint32_t(share(rng) * cube->data->vertex_count()) % cube->data->vertex_count());
            out.push_back(glm::dvec3(p) + glm::dvec3(unit(rng), unit(rng), unit(rng)) * (0.01 * reach * size));
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
    for (const Kappas& kappa : kappa_sets())
        expect_watertight(*model_, kappa, eyes(102, largest_kappa(*model_, *kappa, 1) / 2), 15,
                          [](const auto& triangles) { return odd_edges(triangles); });
}

TEST_F(HlodSelection, CubeKappasNest) {
    // However the cubes' errors differ, a cube's κ is at most 2κ − 1 − 3σ0 − 0.25 of its parent's and of
    // each of its parent's neighbours' (each vertex's morph band a quarter cube wide, neighbours within
    // a level), and every κ ≥ 1 + 3σ0 + 0.25, for any view and target.
    const HlodHeader& h = model_->header();
    Camera camera;
    size_t varied = 0;
    for (double fov : {20.0, 50.0, 120.0})
        for (int width : {320, 1920, 7680})
            for (double pixels : {0.1, 1.0, 16.0, 1e6}) {
                camera.fov_y_degrees = fov, camera.width = width, camera.height = width / 2;
                model_->set_pixel_error(pixels);
                const Kappas kappa = model_->kappas_for(camera);
                std::vector<double> lo(h.max_level + 1, INFINITY), hi(h.max_level + 1, 0.0);
                for (uint32_t c = 0; c < model_->cubes().size(); ++c) {
                    const uint32_t level = model_->cubes()[c].node.level;
                    lo[level] = std::min(lo[level], (*kappa)[c]), hi[level] = std::max(hi[level], (*kappa)[c]);
                    EXPECT_GE((*kappa)[c], model_->min_kappa0());
                    if (model_->parent(c) == kNoCube) continue;
                    for (const uint32_t n : model_->neighbours(model_->parent(c)))
                        if (n != kNoCube) {
                            EXPECT_LE((*kappa)[c], 2 * (*kappa)[n] - 1.25 - 3 * h.sigma0 + 1e-12) << describe_cube(model_->cubes()[c].node);
                        }
                }
                for (uint32_t l = 0; l <= h.max_level; ++l) varied += hi[l] > 1.2 * lo[l];
            }
    EXPECT_GT(varied, 0u) << "some level's cubes should get κ of their own";
    model_->set_kappa0(2.0);
}

TEST_F(HlodSelection, NeighbouringCubesDifferByAtMostOneLevel) {
    for (const Kappas& kappa : kappa_sets()) {
    std::vector<uint32_t> cubes;
    for (const glm::dvec3& eye : eyes(40)) {
        model_->select({eye, kappa}, cubes);
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
}

// Lemma 2: with the eye where a cube just stops being suitable, its children's morphed triangles are
// exactly its own (each child vertex at its parent, the parent's vertices unmoved): no pop.
TEST_F(HlodSelection, ChildrenAtTheSwitchDrawTheParentsTriangles) {
    for (const Kappas& kappa : kappa_sets()) expect_no_pop(*model_, *kappa, 20);
}

TEST_F(HlodSelection, CubesOutsideTheFrustumAreNotSelected) {
    const HlodHeader& h = model_->header();
    const glm::dvec3 centre = 0.5 * glm::dvec3(h.root_size);
    Camera camera;
    camera.look_at(centre + glm::dvec3(0, 0, 1.2 * h.root_size), centre + glm::dvec3(0, 0, 2 * h.root_size));  // looking away
    const glm::dmat4 clip = camera.projection_matrix(0.001, 10 * h.root_size) * camera.view_matrix();
    const Frustum frustum = Frustum::from_matrix(clip);
    std::vector<uint32_t> cubes;
    model_->select({camera.position, model_->uniform_kappas(2.5), &frustum}, cubes);
    EXPECT_TRUE(cubes.empty());
    // Looking at the centre from close by: fewer cubes than without culling, and every one in view.
    camera.look_at(centre + glm::dvec3(0.1, 0.05, 0.3) * h.root_size, centre);
    const Frustum facing = Frustum::from_matrix(camera.projection_matrix(0.001, 10 * h.root_size) * camera.view_matrix());
    std::vector<uint32_t> all;
    model_->select({camera.position, model_->uniform_kappas(2.5)}, all);
    model_->select({camera.position, model_->uniform_kappas(2.5), &facing}, cubes);
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
    camera.look_at(centre + glm::dvec3(0.18, 0.36, 1.6) * size, centre);
    const Kappas kappa = model_->kappas_for(camera);
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
        model_->select({eye, kappa}, expected);
        EXPECT_EQ(cubes, expected);
        drawn.push_back(cubes);
    }
    EXPECT_NE(drawn[0], drawn[1]);
    EXPECT_GT(level_spread(*model_, drawn[0]), 0u) << "the near copy, seen from close by, mixes levels";
    near->remove(model_.get());
    far->remove(model_.get());
}

// Streaming's stand-ins (DESIGN.md §7, nodes/README.md): with cubes missing at random (the root's
// children resident, as the coarse levels stay; each other sibling group resident with probability 0.6
// when its parent is), every drawn cube is resident, the drawn cut is watertight
// with the morph and neighbours differ by at most one level, with one κ and per-cube κ; and cubes
// with a missing child do get drawn where their children would have been.
TEST_F(HlodSelection, MissingCubesAreStoodInForByTheirParentsWithoutCracks) {
    const auto& cubes = model_->cubes();
    std::vector<uint32_t> coarse_first(cubes.size());
    for (uint32_t c = 0; c < cubes.size(); ++c) coarse_first[c] = c;
    std::stable_sort(coarse_first.begin(), coarse_first.end(),
                     [&](uint32_t a, uint32_t b) { return cubes[a].node.level < cubes[b].node.level; });
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> share(0, 1);
    size_t stand_ins_drawn = 0;
    for (int trial = 0; trial < 4; ++trial) {
        std::vector<uint8_t> resident(cubes.size(), 0);
        resident[model_->root()] = 1;
        for (const uint32_t c : coarse_first) {
            const bool group = resident[c] && (cubes[c].node.level == 0 || share(rng) < 0.6);
            for (const uint32_t child : cubes[c].children)
                if (child != kNoCube) resident[child] = group;
        }
        model_->set_residency(resident);
        for (const Kappas& kappa : kappa_sets()) {
            const auto views = eyes(40, largest_kappa(*model_, *kappa, 1) / 2);
            expect_watertight(*model_, kappa, views, 5, [](const auto& triangles) { return odd_edges(triangles); });
            std::vector<uint32_t> drawn;
            for (const glm::dvec3& eye : views) {
                model_->select({eye, kappa}, drawn);
                for (const uint32_t a : drawn) {
                    ASSERT_TRUE(model_->resident(a)) << describe_cube(cubes[a].node);
                    for (const uint32_t child : cubes[a].children) stand_ins_drawn += child != kNoCube && !resident[child];
                    for (const uint32_t b : drawn) {
                        const Box ca = model_->cell(cubes[a].node), cb = model_->cell(cubes[b].node);
                        if (glm::all(glm::lessThanEqual(ca.lo, cb.hi)) && glm::all(glm::lessThanEqual(cb.lo, ca.hi))) {
                            EXPECT_LE(std::abs(int(cubes[a].node.level) - int(cubes[b].node.level)), 1);
                        }
                    }
                }
            }
        }
    }
    EXPECT_GT(stand_ins_drawn, 100u);
    std::vector<uint8_t> partial(cubes.size(), 1);
    partial[model_->root()] = 0;
    EXPECT_THROW(model_->set_residency(partial), std::invalid_argument);  // children without their parent
    model_->set_residency(std::vector<uint8_t>(cubes.size(), 1));
}

// The promise of --pixel-error P (DESIGN.md §8, nodes/README.md), checked from the geometry, not from
// the κ formulas: with the κ kappas_for() gives a 1920 × 1080 60° camera, every drawn cube's error
// bound, seen from the eye at the nearest point the cube can draw anything (its cull box) and magnified
// as the image's corner magnifies (f/r·(1 + tan²(θx/2) + tan²(θy/2))), spans at most P pixels; and where
// a vertex morphs toward its parent, the parent cube's bound does too at that vertex. The full
// resolution is as exact as it gets, drawn as close as the eye likes: outside the promise. Returns the
// triangles drawn over the views, per target; every level must get drawn, and for each target some
// cube must come within 4× of it (the bound is not met by drawing everything finer than needed).
std::vector<uint64_t> expect_pixel_error_kept(HlodModel& model, const std::vector<glm::dvec3>& views,
                                              const std::vector<double>& targets) {
    const HlodHeader& h = model.header();
    Camera camera;
    camera.width = 1920, camera.height = 1080, camera.fov_y_degrees = 60;
    const double tx = camera.tan_half_fov_x(), ty = std::tan(glm::radians(30.0));
    const double magnification = camera.width / (2 * tx) * (1 + tx * tx + ty * ty);  // pixels per unit at unit distance
    auto distance_to = [](const glm::dvec3& p, const Box& box) {
        return glm::length(glm::max(glm::dvec3(0.0), glm::max(box.lo - p, p - box.hi)));
    };
    std::vector<uint64_t> triangles_per_target;
    std::set<uint32_t> levels_drawn;
    for (const double pixels : targets) {
        model.set_pixel_error(pixels);
        const Kappas kappa = model.kappas_for(camera);
        uint64_t triangles = 0;
        double worst = 0;
        std::vector<uint32_t> cubes;
        std::vector<glm::vec3> morphed;
        for (const glm::dvec3& eye : views) {
            model.select({eye, kappa}, cubes);
            for (uint32_t c : cubes) {
                const HlodCube& cube = model.cubes()[c];
                const uint32_t level = cube.node.level;
                levels_drawn.insert(level);
                triangles += cube.data->triangle_count();
                if (level < h.max_level) {
                    const double error = cube.node.error, distance = distance_to(eye, model.cull_box(cube.node));
                    const double projected = distance > error ? error * magnification / (distance - error) : INFINITY;
                    EXPECT_LE(projected, pixels) << describe_cube(cube.node) << " for P " << pixels << " from "
                                                 << eye.x << " " << eye.y << " " << eye.z;
                    worst = std::max(worst, projected);
                }
                if (level == 0) continue;
                const HlodModel::LatticeAnchor anchor = model.anchor_at(eye);
                model.morphed_positions(c, anchor, *kappa, morphed);
                double nearest_morphing = INFINITY;
                for (uint32_t v = 0; v < cube.data->vertex_count(); ++v) {
                    const glm::vec3 own = model.vertex_position(cube, v);
                    if (morphed[v] != model.anchored_position(cube.node.level, model.lattice_steps(cube, v), anchor))
                        nearest_morphing = std::min(nearest_morphing, glm::length(eye - glm::dvec3(own)));
                }
                const double parent_error = model.cubes()[model.parent(c)].node.error;
                EXPECT_LE(parent_error * magnification / (nearest_morphing - parent_error), pixels)
                    << describe_cube(cube.node) << " morphing toward its parent, P " << pixels;
            }
        }
        EXPECT_GT(worst, pixels / 4) << "P " << pixels;
        triangles_per_target.push_back(triangles);
    }
    EXPECT_EQ(levels_drawn.size(), h.max_level + 1u);
    return triangles_per_target;
}

// Eyes from `centre` in random directions, from 1/e to `far` times `size` away.
std::vector<glm::dvec3> eyes_around(const glm::dvec3& centre, double size, double far, int count) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(-1, 1), exponent(-1, std::log(far));
    std::vector<glm::dvec3> out;
    for (int i = 0; i < count; ++i) {
        const glm::dvec3 dir = glm::normalize(glm::dvec3{unit(rng), unit(rng), unit(rng)});
        out.push_back(centre + dir * size * std::exp(exponent(rng)));
    }
    return out;
}

// Eyes from just off the surface to far away, so every level gets drawn.
TEST_F(HlodSelection, PixelErrorBoundsTheProjectedErrorOfEveryDrawnCube) {
    const HlodHeader& h = model_->header();
    std::vector<glm::dvec3> views = eyes(40);
    for (const glm::dvec3& eye : eyes_around(0.5 * glm::dvec3(h.root_size), h.root_size, 80, 60)) views.push_back(eye);
    const auto triangles_per_target = expect_pixel_error_kept(*model_, views, {1.0, 4.0, 16.0});
    // A coarser target draws fewer triangles.
    EXPECT_GT(triangles_per_target[0], triangles_per_target[1]);
    EXPECT_GT(triangles_per_target[1], triangles_per_target[2]);

    // However coarse the target, κ stays where the morph works: κ ≥ 1 + 3σ0 + 0.25 (DESIGN.md §3).
    Camera camera;
    const double morph_minimum = 1.0 + 3.0 * double(h.sigma0) + 0.25;
    model_->set_pixel_error(1e6);
    const Kappas coarsest = model_->kappas_for(camera);
    for (uint32_t c = 0; c < model_->cubes().size(); ++c) EXPECT_DOUBLE_EQ((*coarsest)[c], morph_minimum);
    model_->set_kappa0(0.5);
    EXPECT_DOUBLE_EQ(model_->kappa0(), morph_minimum);
    EXPECT_DOUBLE_EQ((*model_->kappas_for(camera))[model_->root()], morph_minimum);
    EXPECT_THROW(model_->set_pixel_error(-1), std::invalid_argument);
    model_->set_kappa0(2.0);
}

// The promise for the node as the renderer culls it, in world units: under a rotation and a uniform
// scale, for 120° views in a tall and a wide image and a narrow 20° one, every drawn cube's bound
// (scaled) seen from the world eye at its cull box's nearest point (as far in world units as the scale
// makes it) spans at most P pixels at the image's corner magnification.
TEST_F(HlodSelection, PixelErrorHoldsUnderATransformForWideAndTallViews) {
    auto root = std::make_shared<Group>();
    auto place = std::make_shared<Transform>();
    const double scale = 3.7;
    place->set_matrix(glm::scale(glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(5, -2, 1)), glm::radians(33.0),
                                             glm::normalize(glm::dvec3(1, 2, 0.5))),
                                 glm::dvec3(scale)));
    place->add(model_);
    root->add(place);
    const Box bound = root->bound();
    const double max_level = model_->header().max_level;
    struct View {
        double fov;
        int width, height;
    };
    size_t cubes_checked = 0;
    double worst = 0;
    for (const View& v : {View{120, 600, 1200}, View{120, 2400, 600}, View{20, 1000, 1000}}) {
        Camera camera;
        camera.fov_y_degrees = v.fov, camera.width = v.width, camera.height = v.height;
        const double tx = camera.tan_half_fov_x(), ty = std::tan(glm::radians(v.fov) / 2);
        const double magnification = camera.width / (2 * tx) * (1 + tx * tx + ty * ty);
        for (const double pixels : {1.0, 8.0}) {
            model_->set_pixel_error(pixels);
            for (const glm::dvec3& eye : eyes_around(bound.center(), bound.radius(), 60, 30)) {
                camera.look_at(eye, bound.center());
                auto [near_plane, far_plane] = camera.clip_planes_for(bound);
                RenderList list;
                CullVisitor cull(camera, camera.view_matrix(), camera.projection_matrix(near_plane, far_plane), list);
                cull.set_frustum_culling(false);
                root->accept(cull);
                ASSERT_EQ(list.opaque.size(), 1u);
                const DrawItem& item = list.opaque.front();
                const glm::dvec3 local_eye = glm::dvec3(glm::inverse(item.model) * glm::dvec4(eye, 1.0)) - model_->origin();
                for (uint32_t k = 0; k < item.count; ++k) {
                    const HlodNode& node = model_->cubes()[list.item_data[item.first + k]].node;
                    if (node.level == max_level) continue;
                    const Box box = model_->cull_box(node);
                    const double error = scale * node.error;
                    const double distance = scale * glm::length(glm::max(glm::dvec3(0.0), glm::max(box.lo - local_eye, local_eye - box.hi)));
                    const double projected = distance > error ? error * magnification / (distance - error) : INFINITY;
                    EXPECT_LE(projected, pixels) << describe_cube(node) << ", " << v.fov << "° " << v.width << "x" << v.height;
                    worst = std::max(worst, projected / pixels);
                    ++cubes_checked;
                }
            }
        }
    }
    EXPECT_GT(cubes_checked, 100u);
    EXPECT_GT(worst, 0.25) << "some cube should come near its target";
    place->remove(model_.get());
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

// The same checks on a real terrain, an open surface: 128 × 128 samples of trinidad.nc (the Sangre de
// Cristo range). Its edges used once must make one loop, its outline (which simplification moves
// inwards at coarse levels); a crack away from it is a loop of its own.
class TerrainSelection : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        const auto dem = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "trinidad.nc";
        if (!std::filesystem::exists(dem)) return;
        test::TempDir dir;
        BuildSettings settings;
        settings.levels = 3;
        build_hlod(test::read_dem_grid(dem, {.first_column = 620, .first_row = 600, .columns = 128, .rows = 128},
                                       {.variable = "", .unit = test::ElevationUnit::feet}),
                   dir / "terrain.hlod", settings, "trinidad.nc");
        model_ = HlodModel::load(dir / "terrain.hlod");
    }
    static void TearDownTestSuite() { model_.reset(); }
    void SetUp() override {
        if (!model_) GTEST_SKIP() << "data/trinidad.nc missing: run scripts/setup.sh";
    }
    // Eyes over the terrain and beyond its edges, from just above the ground to far above it.
    static std::vector<glm::dvec3> eyes(int count, double reach) {
        std::mt19937 rng(2027);
        std::uniform_real_distribution<double> share(0, 1);
        const double size = model_->header().root_size;
        std::vector<glm::dvec3> out;
        for (int i = 0; i < count; ++i) {
            const glm::dvec3 extent = model_->bound().hi - model_->bound().lo;
            const double x = (share(rng) * 1.6 - 0.3) * extent.x, y = (share(rng) * 1.6 - 0.3) * extent.y;
            out.push_back({x, y, model_->bound().hi.z - model_->origin().z + size * reach * std::pow(share(rng), 2)});
        }
        return out;
    }

    static inline std::shared_ptr<HlodModel> model_;
};

TEST_F(TerrainSelection, WatertightInsideItsOutlineWithTheMorphAndCrackedWithout) {
    Camera camera;
    camera.width = 1920, camera.height = 1080, camera.fov_y_degrees = 60;
    for (double pixels : {0.0, 64.0, 256.0}) {
        if (pixels > 0) model_->set_pixel_error(pixels);
        const Kappas kappa = model_->kappas_for(camera);
        // Loops beyond the outline's one.
        expect_watertight(*model_, kappa, eyes(60, largest_kappa(*model_, *kappa, 1) / 2), 15,
                          [](const auto& triangles) { return boundary_loops(triangles) - 1; });
        expect_no_pop(*model_, *kappa, 20);
    }
    model_->set_kappa0(2.0);
}

TEST_F(TerrainSelection, PixelErrorBoundsTheProjectedErrorOfEveryDrawnCube) {
    const double size = model_->header().root_size;
    std::vector<glm::dvec3> views = eyes(40, 1);
    for (const glm::dvec3& eye : eyes_around(0.5 * glm::dvec3(size), size, 80, 60)) views.push_back(eye);
    expect_pixel_error_kept(*model_, views, {1.0, 4.0, 16.0});
    model_->set_kappa0(2.0);
}

// The spatially varying bound at work: where a cube's bound (or its parent's) is smaller than its
// level's largest, its κ is smaller and the selection draws it from closer, so the same pixel target
// draws fewer triangles than one κ per level (each level's largest) would, the crack and pixel checks
// above holding all the same.
TEST_F(TerrainSelection, CubesWithSmallerBoundsAreDrawnFromCloser) {
    Camera camera;
    camera.width = 1920, camera.height = 1080, camera.fov_y_degrees = 60;
    for (const double pixels : {1.0, 16.0}) {
        model_->set_pixel_error(pixels);
        const Kappas per_cube = model_->kappas_for(camera);
        auto per_level = std::make_shared<CubeKappas>(*per_cube);
        for (uint32_t c = 0; c < model_->cubes().size(); ++c)
            per_level->kappa[c] = largest_kappa(*model_, *per_cube, model_->cubes()[c].node.level);
        uint64_t triangles_per_cube = 0, triangles_per_level = 0;
        std::vector<uint32_t> cubes;
        for (const glm::dvec3& eye : eyes(60, largest_kappa(*model_, *per_cube, 1) / 2)) {
            model_->select({eye, per_cube}, cubes);
            for (uint32_t c : cubes) triangles_per_cube += model_->cubes()[c].data->triangle_count();
            model_->select({eye, per_level}, cubes);
            for (uint32_t c : cubes) triangles_per_level += model_->cubes()[c].data->triangle_count();
        }
        EXPECT_LT(double(triangles_per_cube), 0.9 * double(triangles_per_level)) << "P " << pixels;
        std::printf("P %g: %llu triangles with κ per cube, %llu with each level's largest\n", pixels,
                    (unsigned long long)triangles_per_cube, (unsigned long long)triangles_per_level);
    }
    model_->set_kappa0(2.0);
}

}  // namespace
}  // namespace strata
