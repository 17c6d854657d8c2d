// Error quadrics and the block simplifier (DESIGN.md §2 "Simplification", "Parent map") on small
// hand-made BlockMesh inputs: where every wedge goes, what may not move, how far anything travels,
// closed stays closed, seams and the open boundary keep their shape, determinism and the error limit.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "preprocess/quadric.h"
#include "preprocess/simplify.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

// ---- quadrics -------------------------------------------------------------------------------------

TEST(Quadric, OnePlaneGivesWeightedSquaredDistance) {
    Quadric q;
    q.add_plane({0, 0, 1}, -1.0f, 2.0f);  // the plane z = 1, weight 2
    EXPECT_FLOAT_EQ(q.weight, 2.0f);
    EXPECT_FLOAT_EQ(q.evaluate({0, 0, 1}), 0.0f);
    EXPECT_FLOAT_EQ(q.evaluate({5, -7, 1}), 0.0f);    // anywhere on the plane
    EXPECT_FLOAT_EQ(q.evaluate({3, 4, 4}), 2.0f * 9);  // 3 above it
    EXPECT_FLOAT_EQ(q.evaluate({0, 0, -1}), 2.0f * 4);  // 2 below it

    // An oblique plane: n = (1, 1, 0)/√2 through (1, 0, 0), i.e. x + y = 1.
    const float r = 1.0f / std::sqrt(2.0f);
    Quadric oblique;
    oblique.add_plane({r, r, 0}, -r, 0.5f);
    EXPECT_NEAR(oblique.evaluate({0.5f, 0.5f, 9}), 0.0f, 1e-6f);
    EXPECT_NEAR(oblique.evaluate({2, 2, -3}), 0.5f * (3 * r) * (3 * r), 1e-5f);  // distance 3/√2
    EXPECT_NEAR(oblique.evaluate({0, 0, 0}), 0.5f * 0.5f, 1e-6f);               // distance 1/√2
}

TEST(Quadric, SumOfPlanes) {
    Quadric q;
    q.add_plane({1, 0, 0}, 0.0f, 1.0f);   // x = 0
    q.add_plane({0, 1, 0}, -2.0f, 3.0f);  // y = 2
    q.add_plane({0, 0, -1}, 4.0f, 0.5f);  // z = 4 (normal facing down: the sign does not matter)
    EXPECT_FLOAT_EQ(q.weight, 4.5f);
    const Vec3 p{1, 5, 7};
    EXPECT_FLOAT_EQ(q.evaluate(p), 1.0f * 1 + 3.0f * 9 + 0.5f * 9);
    EXPECT_FLOAT_EQ(q.evaluate({0, 2, 4}), 0.0f);  // the three planes meet there
    // The mean squared distance, as the simplifier reads it.
    EXPECT_FLOAT_EQ(q.evaluate(p) / q.weight, (1.0f + 27.0f + 4.5f) / 4.5f);
}

TEST(Quadric, EvaluateIsNeverNegative) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1, 1), far(-1000, 1000), w(0.01f, 10);
    for (int trial = 0; trial < 200; ++trial) {
        Quadric q;
        std::vector<std::pair<Vec3, float>> planes;
        for (int k = 0; k < 1 + trial % 4; ++k) {
            Vec3 n{u(rng), u(rng), u(rng)};
            n = n * (1.0f / length(n));
            const float d = far(rng);
            q.add_plane(n, d, w(rng));
            planes.emplace_back(n, d);
        }
        // Points on the planes, where rounding in the expanded form could dip below zero.
        for (auto [n, d] : planes) {
            Vec3 p = n * -d;
            EXPECT_GE(q.evaluate(p), 0.0f);
        }
        for (int k = 0; k < 20; ++k) EXPECT_GE(q.evaluate({far(rng), far(rng), far(rng)}), 0.0f);
        EXPECT_GE(Quadric{}.evaluate({far(rng), far(rng), far(rng)}), 0.0f);
    }
}

TEST(Quadric, AddEqualsAddingThePlanesOneByOne) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1, 1), w(0.1f, 3);
    struct Plane {
        Vec3 n;
        float d, w;
    };
    std::vector<Plane> planes;
    for (int k = 0; k < 6; ++k) {
        Vec3 n{u(rng), u(rng), u(rng)};
        planes.push_back({n * (1.0f / length(n)), 5 * u(rng), w(rng)});
    }
    Quadric one_by_one, summed;
    for (const Plane& p : planes) {
        one_by_one.add_plane(p.n, p.d, p.w);
        Quadric single;
        single.add_plane(p.n, p.d, p.w);
        summed.add(single);
    }
    // Same additions in the same order: the same bits.
    EXPECT_EQ(summed.a00, one_by_one.a00);
    EXPECT_EQ(summed.a11, one_by_one.a11);
    EXPECT_EQ(summed.a22, one_by_one.a22);
    EXPECT_EQ(summed.a10, one_by_one.a10);
    EXPECT_EQ(summed.a20, one_by_one.a20);
    EXPECT_EQ(summed.a21, one_by_one.a21);
    EXPECT_EQ(summed.b0, one_by_one.b0);
    EXPECT_EQ(summed.b1, one_by_one.b1);
    EXPECT_EQ(summed.b2, one_by_one.b2);
    EXPECT_EQ(summed.c, one_by_one.c);
    EXPECT_EQ(summed.weight, one_by_one.weight);

    // Merging two partial sums evaluates like the sum of their evaluations.
    Quadric first, second;
    for (size_t k = 0; k < planes.size(); ++k) (k < 3 ? first : second).add_plane(planes[k].n, planes[k].d, planes[k].w);
    Quadric merged = first;
    merged.add(second);
    for (int k = 0; k < 20; ++k) {
        Vec3 p{3 * u(rng), 3 * u(rng), 3 * u(rng)};
        float expected = 0;
        for (const Plane& pl : planes) expected += pl.w * (dot(pl.n, p) + pl.d) * (dot(pl.n, p) + pl.d);
        EXPECT_NEAR(merged.evaluate(p), expected, 1e-3f * (1 + expected));
        EXPECT_NEAR(merged.evaluate(p), first.evaluate(p) + second.evaluate(p), 1e-3f * (1 + expected));
    }
}

// ---- BlockMesh fixtures -----------------------------------------------------------------------------

// An n×n grid of quads with `spacing`, heights from `height(x, y)`, one wedge per point; optionally a
// seam down column `seam`: its points get a second wedge, used by the quads right of it, and every
// wedge carries two attributes (u scaled, v scaled) with the right chart's u shifted by 1.
struct Grid {
    BlockMesh mesh;
    int n = 0;
    std::vector<int> chart;  // per wedge: 0 left, 1 right (all 0 without a seam)
    uint32_t point(int x, int y) const { return uint32_t(y * (n + 1) + x); }
    bool on_outline(uint32_t p) const {
        int x = int(p) % (n + 1), y = int(p) / (n + 1);
        return x == 0 || y == 0 || x == n || y == n;
    }
};

template <class Height>
Grid make_grid(int n, float spacing, Height height, int seam = -1) {
    Grid g;
    g.n = n;
    BlockMesh& m = g.mesh;
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) {
            m.point_positions.insert(m.point_positions.end(), {x * spacing, y * spacing, height(x, y)});
            m.point_locked.push_back(0);
            m.wedge_point.push_back(g.point(x, y));
            g.chart.push_back(seam >= 0 && x > seam ? 1 : 0);
        }
    std::vector<uint32_t> right(m.wedge_point.size());
    for (uint32_t w = 0; w < right.size(); ++w) right[w] = w;
    if (seam >= 0) {
        for (int y = 0; y <= n; ++y) {
            right[g.point(seam, y)] = uint32_t(m.wedge_point.size());
            m.wedge_point.push_back(g.point(seam, y));
            g.chart.push_back(1);
        }
        m.attribute_count = 2;
        for (uint32_t w = 0; w < m.wedge_point.size(); ++w) {
            const float* p = &m.point_positions[3 * m.wedge_point[w]];
            m.wedge_attributes.push_back(0.5f * (p[0] / (n * spacing) + float(g.chart[w])));
            m.wedge_attributes.push_back(0.5f * p[1] / (n * spacing));
        }
    }
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            auto at = [&](int i, int j) { return seam >= 0 && x >= seam ? right[g.point(i, j)] : g.point(i, j); };
            m.triangles.insert(m.triangles.end(), {at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y), at(x + 1, y + 1), at(x, y + 1)});
        }
    return g;
}

Grid flat_grid(int n) {
    return make_grid(n, 0.1f, [](int, int) { return 0.0f; });
}
Grid curved_grid(int n, int seam = -1) {
    return make_grid(n, 0.1f, [n](int x, int y) { return 0.15f * std::sin(6.0f * x / n) * std::cos(5.0f * y / n); }, seam);
}

// A closed mesh: one point and one wedge per vertex.
BlockMesh block_from(const Mesh& mesh) {
    BlockMesh m;
    m.point_positions = mesh.positions;
    m.point_locked.assign(mesh.vertex_count(), 0);
    for (uint32_t v = 0; v < mesh.vertex_count(); ++v) m.wedge_point.push_back(v);
    m.triangles = mesh.indices;
    return m;
}

using Tri = std::array<uint32_t, 3>;

// The triangles mapped through wedge_remap, without those that collapsed (two corners on one point).
std::vector<Tri> mapped_triangles(const BlockMesh& m, const SimplifyResult& r) {
    std::vector<Tri> out;
    for (size_t t = 0; t < m.triangles.size(); t += 3) {
        Tri tri{r.wedge_remap[m.triangles[t]], r.wedge_remap[m.triangles[t + 1]], r.wedge_remap[m.triangles[t + 2]]};
        uint32_t a = m.wedge_point[tri[0]], b = m.wedge_point[tri[1]], c = m.wedge_point[tri[2]];
        if (a != b && b != c && a != c) out.push_back(tri);
    }
    return out;
}

// Directed point edges of mapped triangles, with their multiplicity.
std::map<std::pair<uint32_t, uint32_t>, int> directed_edges(const BlockMesh& m, const std::vector<Tri>& tris) {
    std::map<std::pair<uint32_t, uint32_t>, int> edges;
    for (const Tri& t : tris)
        for (int c = 0; c < 3; ++c) ++edges[{m.wedge_point[t[c]], m.wedge_point[t[(c + 1) % 3]]}];
    return edges;
}

// wedge_remap is final (every entry a survivor), sizes agree, triangles_left counts the mapped triangles,
// and the seam copies of one point all land on one point.
void expect_consistent(const BlockMesh& m, const SimplifyResult& r) {
    ASSERT_EQ(r.wedge_remap.size(), m.wedge_count());
    ASSERT_EQ(r.point_error.size(), m.point_count());
    for (uint32_t w = 0; w < m.wedge_count(); ++w) {
        ASSERT_LT(r.wedge_remap[w], m.wedge_count()) << "wedge " << w;
        EXPECT_EQ(r.wedge_remap[r.wedge_remap[w]], r.wedge_remap[w]) << "wedge " << w << " maps to a collapsed wedge";
    }
    std::vector<uint32_t> point_target(m.point_count(), ~0u);
    for (uint32_t w = 0; w < m.wedge_count(); ++w) {
        uint32_t& target = point_target[m.wedge_point[w]];
        uint32_t p = m.wedge_point[r.wedge_remap[w]];
        if (target == ~0u) target = p;
        EXPECT_EQ(p, target) << "the wedges of point " << m.wedge_point[w] << " went to different points";
    }
    EXPECT_EQ(mapped_triangles(m, r).size(), r.triangles_left);
    for (float e : r.point_error) {
        EXPECT_TRUE(std::isfinite(e));
        EXPECT_GE(e, 0.0f);
    }
}

float linf(const BlockMesh& m, uint32_t p, uint32_t q) {
    float d = 0;
    for (int a = 0; a < 3; ++a) d = std::max(d, std::fabs(m.point_positions[3 * p + a] - m.point_positions[3 * q + a]));
    return d;
}

// ---- simplify_block -------------------------------------------------------------------------------

TEST(SimplifyBlock, FlatGridReachesTargetWithZeroError) {
    Grid g = flat_grid(10);  // 200 triangles
    SimplifyLimits limits;
    limits.target_triangles = 50;
    SimplifyResult r = simplify_block(g.mesh, limits);
    ASSERT_NO_FATAL_FAILURE(expect_consistent(g.mesh, r));
    EXPECT_LE(r.triangles_left, 50u);
    EXPECT_GE(r.triangles_left, 30u);  // one collapse removes at most two triangles: no big overshoot
    EXPECT_LT(*std::max_element(r.point_error.begin(), r.point_error.end()), 1e-5f);
    // Every point stays in the plane and the mapped triangles keep facing up (no fold).
    for (const Tri& t : mapped_triangles(g.mesh, r)) {
        const float* p[3];
        for (int c = 0; c < 3; ++c) p[c] = &g.mesh.point_positions[3 * g.mesh.wedge_point[t[c]]];
        Vec3 a{p[0][0], p[0][1], p[0][2]}, b{p[1][0], p[1][1], p[1][2]}, d{p[2][0], p[2][1], p[2][2]};
        EXPECT_GT(cross(b - a, d - a).z, 0.0f);
    }
    // The four corners shape the outline: collapsing one would cost; none moved.
    for (uint32_t corner : {g.point(0, 0), g.point(10, 0), g.point(0, 10), g.point(10, 10)})
        EXPECT_EQ(r.wedge_remap[corner], corner);
}

TEST(SimplifyBlock, NothingToDoLeavesEverythingInPlace) {
    Grid g = flat_grid(4);
    SimplifyLimits limits;
    limits.target_triangles = g.mesh.triangle_count();
    SimplifyResult r = simplify_block(g.mesh, limits);
    EXPECT_EQ(r.triangles_left, g.mesh.triangle_count());
    for (uint32_t w = 0; w < g.mesh.wedge_count(); ++w) EXPECT_EQ(r.wedge_remap[w], w);
    for (float e : r.point_error) EXPECT_EQ(e, 0.0f);
}

TEST(SimplifyBlock, LockedPointsNeverMove) {
    Grid g = curved_grid(10);
    // Lock the middle row and every third column, like block-border points.
    std::vector<uint32_t> locked;
    for (uint32_t p = 0; p < g.mesh.point_count(); ++p) {
        int x = int(p) % 11, y = int(p) / 11;
        if (y == 5 || x % 3 == 0) g.mesh.point_locked[p] = 1, locked.push_back(p);
    }
    SimplifyLimits limits;
    limits.target_triangles = 20;
    SimplifyResult r = simplify_block(g.mesh, limits);
    ASSERT_NO_FATAL_FAILURE(expect_consistent(g.mesh, r));
    EXPECT_LT(r.triangles_left, 150u);  // the free points did collapse
    std::set<uint32_t> targets;
    for (uint32_t w = 0; w < g.mesh.wedge_count(); ++w) {
        if (g.mesh.point_locked[g.mesh.wedge_point[w]]) EXPECT_EQ(r.wedge_remap[w], w) << "locked wedge " << w << " moved";
        else if (r.wedge_remap[w] != w) targets.insert(g.mesh.wedge_point[r.wedge_remap[w]]);
    }
    // A locked point may still be a collapse target.
    EXPECT_TRUE(std::any_of(targets.begin(), targets.end(), [&](uint32_t p) { return g.mesh.point_locked[p] != 0; }));
}

TEST(SimplifyBlock, TinyMaxTravelCollapsesNothing) {
    Grid g = curved_grid(10);
    SimplifyLimits limits;
    limits.target_triangles = 10;
    limits.max_travel = 0.01f;  // a tenth of the spacing
    SimplifyResult r = simplify_block(g.mesh, limits);
    EXPECT_EQ(r.triangles_left, g.mesh.triangle_count());
    for (uint32_t w = 0; w < g.mesh.wedge_count(); ++w) EXPECT_EQ(r.wedge_remap[w], w);
}

TEST(SimplifyBlock, MaxTravelBoundsEveryMergedPoint) {
    for (float travel : {0.12f, 0.25f}) {
        Grid g = curved_grid(10);
        SimplifyLimits limits;
        limits.target_triangles = 2;
        limits.max_travel = travel;
        SimplifyResult r = simplify_block(g.mesh, limits);
        ASSERT_NO_FATAL_FAILURE(expect_consistent(g.mesh, r));
        EXPECT_LT(r.triangles_left, 200u) << "travel " << travel;  // collapses happened…
        EXPECT_GT(r.triangles_left, 2u) << "travel " << travel;    // …but the bound stopped them
        size_t moved = 0;
        for (uint32_t w = 0; w < g.mesh.wedge_count(); ++w) {
            uint32_t from = g.mesh.wedge_point[w], to = g.mesh.wedge_point[r.wedge_remap[w]];
            if (from == to) continue;
            ++moved;
            EXPECT_LE(linf(g.mesh, from, to), travel) << "point " << from << " → " << to << ", travel " << travel;
        }
        EXPECT_GT(moved, 0u);
    }
    // Without the bound the same grid goes much further.
    Grid g = curved_grid(10);
    SimplifyLimits unbounded;
    unbounded.target_triangles = 2;
    SimplifyLimits bounded = unbounded;
    bounded.max_travel = 0.12f;
    EXPECT_LT(simplify_block(g.mesh, unbounded).triangles_left, simplify_block(g.mesh, bounded).triangles_left);
}

// A torus of `major` × `minor` quads: closed, genus 1, and thin enough that careless collapses pinch it.
BlockMesh torus(int major, int minor, float r_major, float r_minor) {
    BlockMesh m;
    for (int i = 0; i < major; ++i)
        for (int j = 0; j < minor; ++j) {
            float a = 2 * 3.14159265f * float(i) / float(major), b = 2 * 3.14159265f * float(j) / float(minor);
            float rr = r_major + r_minor * std::cos(b);
            m.point_positions.insert(m.point_positions.end(), {rr * std::cos(a), rr * std::sin(a), r_minor * std::sin(b)});
            m.point_locked.push_back(0);
            m.wedge_point.push_back(uint32_t(m.wedge_point.size()));
        }
    auto at = [&](int i, int j) { return uint32_t(((i + major) % major) * minor + (j + minor) % minor); };
    for (int i = 0; i < major; ++i)
        for (int j = 0; j < minor; ++j)
            m.triangles.insert(m.triangles.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    return m;
}

// Closed and manifold (every directed edge once, with its twin); returns V − E + F.
int64_t expect_closed_manifold(const BlockMesh& m, const SimplifyResult& r, const std::string& what) {
    std::vector<Tri> tris = mapped_triangles(m, r);
    auto edges = directed_edges(m, tris);
    std::set<uint32_t> points;
    for (auto& [edge, count] : edges) {
        EXPECT_EQ(count, 1) << "edge " << edge.first << "→" << edge.second << " used twice (" << what << ")";
        auto twin = edges.find({edge.second, edge.first});
        EXPECT_TRUE(twin != edges.end() && twin->second == count)
            << "edge " << edge.first << "→" << edge.second << " has no twin (" << what << ")";
        points.insert(edge.first);
    }
    return int64_t(points.size()) - int64_t(edges.size() / 2) + int64_t(tris.size());
}

TEST(SimplifyBlock, ClosedMeshStaysClosed) {
    Mesh sphere = test::icosphere(2);  // 320 triangles, 162 vertices
    BlockMesh m = block_from(sphere);
    for (uint32_t target : {160u, 80u, 40u, 20u, 12u, 8u}) {
        SimplifyLimits limits;
        limits.target_triangles = target;
        SimplifyResult r = simplify_block(m, limits);
        ASSERT_NO_FATAL_FAILURE(expect_consistent(m, r));
        EXPECT_LE(r.triangles_left, target);
        // Still a sphere: V − E + F = 2.
        EXPECT_EQ(expect_closed_manifold(m, r, "target " + std::to_string(target)), 2) << "target " << target;
    }
}

TEST(SimplifyBlock, ThinTorusIsNeverPinched) {
    BlockMesh m = torus(24, 6, 1.0f, 0.15f);  // 288 triangles
    for (uint32_t target : {100u, 40u, 0u}) {
        SimplifyLimits limits;
        limits.target_triangles = target;
        SimplifyResult r = simplify_block(m, limits);
        ASSERT_NO_FATAL_FAILURE(expect_consistent(m, r));
        EXPECT_LT(r.triangles_left, m.triangle_count());
        EXPECT_EQ(expect_closed_manifold(m, r, "target " + std::to_string(target)), 0) << "no longer a torus";
    }
}

// Flat discs of `rim` points around one shared centre (point 0), all in the plane z = 0, disc k of
// radius k + 1: moving the centre costs nothing and folds nothing, whatever the topology says.
BlockMesh discs_on_one_centre(int discs, int rim) {
    BlockMesh m;
    m.point_positions = {0, 0, 0};
    for (int d = 0; d < discs; ++d)
        for (int i = 0; i < rim; ++i) {
            const float a = 6.2831853f * float(i) / float(rim);
            m.point_positions.insert(m.point_positions.end(), {float(d + 1) * std::cos(a), float(d + 1) * std::sin(a), 0});
        }
    const uint32_t points = uint32_t(m.point_positions.size() / 3);
    m.point_locked.assign(points, 0);
    for (uint32_t p = 0; p < points; ++p) m.wedge_point.push_back(p);
    for (int d = 0; d < discs; ++d)
        for (int i = 0; i < rim; ++i)
            m.triangles.insert(m.triangles.end(), {0u, uint32_t(1 + d * rim + i), uint32_t(1 + d * rim + (i + 1) % rim)});
    return m;
}

TEST(SimplifyBlock, TwoFansOnOnePointKeepItInPlace) {
    // One high-valence disc: its centre is an interior point, free to go (a flat collapse costs nothing).
    SimplifyLimits limits;
    limits.target_triangles = 8;
    const BlockMesh one = discs_on_one_centre(1, 96);
    const SimplifyResult free = simplify_block(one, limits);
    ASSERT_NO_FATAL_FAILURE(expect_consistent(one, free));
    EXPECT_NE(free.wedge_remap[0], 0u) << "the centre of a single disc should have collapsed";
    // Two discs on the same centre, as many triangles there: two surfaces touching at one point,
    // which no collapse may move (it would tear one surface or glue the two).
    const BlockMesh two = discs_on_one_centre(2, 48);
    const SimplifyResult held = simplify_block(two, limits);
    ASSERT_NO_FATAL_FAILURE(expect_consistent(two, held));
    EXPECT_LT(held.triangles_left, two.triangle_count());
    EXPECT_EQ(held.wedge_remap[0], 0u) << "the point two fans share moved";
}

TEST(SimplifyBlock, AttributesNeverCrossASeam) {
    Grid g = curved_grid(10, /*seam=*/5);  // 121 points, 132 wedges
    ASSERT_EQ(g.mesh.wedge_count(), 132u);
    SimplifyLimits limits;
    limits.target_triangles = 30;
    SimplifyResult r = simplify_block(g.mesh, limits);
    ASSERT_NO_FATAL_FAILURE(expect_consistent(g.mesh, r));
    EXPECT_LT(r.triangles_left, 100u);
    size_t seam_moved = 0;
    for (uint32_t w = 0; w < g.mesh.wedge_count(); ++w) {
        EXPECT_EQ(g.chart[r.wedge_remap[w]], g.chart[w]) << "wedge " << w << " crossed the seam";
        const uint32_t p = g.mesh.wedge_point[w];
        if (int(p) % 11 == 5 && r.wedge_remap[w] != w) {
            ++seam_moved;
            // A seam point slides along the seam: its target is a seam point too.
            EXPECT_EQ(int(g.mesh.wedge_point[r.wedge_remap[w]]) % 11, 5) << "seam wedge " << w << " left the seam";
        }
    }
    EXPECT_GT(seam_moved, 0u);  // the seam itself was simplified, both copies together
    for (const Tri& t : mapped_triangles(g.mesh, r))
        EXPECT_TRUE(g.chart[t[0]] == g.chart[t[1]] && g.chart[t[1]] == g.chart[t[2]]) << "a triangle mixes charts";
}

TEST(SimplifyBlock, OpenBoundaryStaysOnTheBoundary) {
    Grid g = curved_grid(10);
    SimplifyLimits limits;
    limits.target_triangles = 2;  // far beyond what the outline allows: boundary collapses get expensive
    SimplifyResult r = simplify_block(g.mesh, limits);
    ASSERT_NO_FATAL_FAILURE(expect_consistent(g.mesh, r));
    EXPECT_LT(r.triangles_left, 50u);
    size_t outline_moved = 0;
    for (uint32_t w = 0; w < g.mesh.wedge_count(); ++w) {
        uint32_t from = g.mesh.wedge_point[w], to = g.mesh.wedge_point[r.wedge_remap[w]];
        if (g.on_outline(from)) {
            EXPECT_TRUE(g.on_outline(to)) << "boundary point " << from << " went inside to " << to;
            outline_moved += from != to;
        }
    }
    EXPECT_GT(outline_moved, 0u);  // the outline is not locked, only kept in shape
    // Every boundary edge of the result runs along the outline, and no interior edge lost its twin.
    auto edges = directed_edges(g.mesh, mapped_triangles(g.mesh, r));
    for (auto& [edge, count] : edges) {
        EXPECT_EQ(count, 1);
        if (!edges.count({edge.second, edge.first})) {
            EXPECT_TRUE(g.on_outline(edge.first) && g.on_outline(edge.second))
                << "boundary edge " << edge.first << "→" << edge.second << " inside the grid";
        }
    }
}

TEST(SimplifyBlock, Deterministic) {
    Grid g = curved_grid(12, /*seam=*/4);
    g.mesh.point_locked[g.point(6, 6)] = 1;
    SimplifyLimits limits;
    limits.target_triangles = 40;
    limits.max_travel = 0.35f;
    SimplifyResult a = simplify_block(g.mesh, limits);
    SimplifyResult b = simplify_block(g.mesh, limits);
    EXPECT_EQ(a.wedge_remap, b.wedge_remap);
    EXPECT_EQ(a.point_error, b.point_error);
    EXPECT_EQ(a.triangles_left, b.triangles_left);
    // A copy of the input (other addresses) gives the same too.
    BlockMesh copy = g.mesh;
    SimplifyResult c = simplify_block(copy, limits);
    EXPECT_EQ(a.wedge_remap, c.wedge_remap);
    EXPECT_EQ(a.point_error, c.point_error);
    EXPECT_EQ(a.triangles_left, c.triangles_left);
}

TEST(SimplifyBlock, MaxErrorStopsCollapses) {
    BlockMesh m = block_from(test::icosphere(2));  // bumpy: no collapse is free
    SimplifyLimits unlimited;
    unlimited.target_triangles = 8;
    SimplifyResult free = simplify_block(m, unlimited);
    const float worst = *std::max_element(free.point_error.begin(), free.point_error.end());
    ASSERT_GT(worst, 0.0f);

    SimplifyLimits limited = unlimited;
    limited.max_error = worst / 4;
    SimplifyResult r = simplify_block(m, limited);
    ASSERT_NO_FATAL_FAILURE(expect_consistent(m, r));
    EXPECT_GT(r.triangles_left, free.triangles_left);
    EXPECT_LT(r.triangles_left, m.triangle_count());  // cheap collapses still happened
    for (float e : r.point_error) EXPECT_LE(e, limited.max_error);

    SimplifyLimits none = unlimited;
    none.max_error = 0;
    SimplifyResult stopped = simplify_block(m, none);
    EXPECT_EQ(stopped.triangles_left, m.triangle_count());
    for (uint32_t w = 0; w < m.wedge_count(); ++w) EXPECT_EQ(stopped.wedge_remap[w], w);
}

// A pocket smaller than a lattice step, as the root of a 1 G-triangle build held one (its two-ring,
// positions in lattice steps): point 17 sits on the tip of a cap over the triangle 13-14-15, which
// meets 13 and 15 at one lattice point. Every collapse of the four folds a face, or meets the link
// condition; left alone the pocket outlives every level and, on the coarse lattice, becomes two faces
// on one edge. Moves below the next level's lattice step skip the fold test (it is gone once
// quantized) and come first among a point's targets: the four become one point.
TEST(SimplifyBlock, APocketSmallerThanTheLatticeCollapsesToAPoint) {
    const float step = 1.0f / 32768;
    const std::vector<std::array<float, 3>> points = {
        {29372, 18388, 39711}, {30290, 19044, 39868}, {27817, 17218, 38442}, {28162, 18175, 38315},
        {29327, 17933, 39929}, {30208, 17804, 40543}, {30375, 17173, 40666}, {29576, 17203, 40126},
        {29622, 16923, 40006}, {30080, 16828, 40209}, {28655, 16885, 38894}, {28134, 16748, 38249},
        {28655, 16904, 38912}, {28646, 16940, 38938}, {28646, 16941, 38938}, {28646, 16940, 38938},
        {28148, 17005, 38484}, {28645, 16940, 38938}};
    BlockMesh m;
    for (const auto& p : points)
        for (float x : p) m.point_positions.push_back(x * step);
    m.point_locked.assign(points.size(), 0);
    for (uint32_t v = 0; v < points.size(); ++v) m.wedge_point.push_back(v);
    m.triangles = {4,  1,  0,  4,  0,  3,  1,  4,  5,  6,  5,  4,  6,  4,  7,  6,  7,  8,  6,  8,
                   9,  10, 11, 9,  10, 9,  8,  12, 8,  7,  8,  12, 10, 13, 7,  4,  7,  13, 12, 10,
                   12, 14, 12, 13, 15, 12, 15, 14, 16, 11, 10, 16, 10, 13, 13, 10, 14, 16, 13, 4,
                   13, 14, 17, 13, 17, 15, 16, 4,  3,  16, 3,  2,  16, 2,  11, 15, 17, 14};
    const uint32_t pocket[] = {13, 14, 15, 17};
    SimplifyLimits limits;
    limits.target_triangles = 0;
    limits.max_travel = 0.125f;
    auto survivors = [&](const SimplifyResult& r) {
        std::set<uint32_t> left;
        for (uint32_t p : pocket) left.insert(r.wedge_remap[p]);
        return left.size();
    };
    const SimplifyResult stuck = simplify_block(m, limits);
    EXPECT_EQ(survivors(stuck), 4u) << "without the rule every collapse of the pocket is refused";

    limits.min_fold = 2 * step;
    const SimplifyResult r = simplify_block(m, limits);
    ASSERT_NO_FATAL_FAILURE(expect_consistent(m, r));
    EXPECT_EQ(survivors(r), 1u);
}

}  // namespace
}  // namespace strata
