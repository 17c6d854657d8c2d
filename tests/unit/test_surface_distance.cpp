// The conservative surface distance behind the builder's error bound (preprocess/surface_distance.h):
// its upper bound is never below a dense brute-force sampling of the true distance, and it is tight
// (within its tolerance) where the answer is known.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "preprocess/surface_distance.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

// An n×n grid of squares on [0, size]² at height z(x, y), two triangles a square, counter-clockwise
// seen from +z. `jitter` moves interior points along the plane (a tangential shift that changes no
// height on a flat grid).
template <class Height>
Mesh height_grid(int n, double size, Height&& z, double jitter = 0, uint32_t seed = 1) {
    Mesh m;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> shift(-jitter, jitter);
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            double x = size * i / n, y = size * j / n;
            if (i > 0 && i < n && j > 0 && j < n) x += shift(rng) * size / n, y += shift(rng) * size / n;
            m.positions.insert(m.positions.end(), {float(x), float(y), float(z(x, y))});
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
    return m;
}

SurfaceView view(const Mesh& m) { return {m.positions, m.indices}; }

// The largest distance over random points of `from` to `to`, brute force (every triangle).
double sampled_distance(const Mesh& from, const Mesh& to, int samples_per_triangle, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0, 1);
    double worst = 0;
    auto p = [](const Mesh& m, uint32_t v, int a) { return double(m.positions[3 * size_t(v) + a]); };
    for (size_t t = 0; t < from.indices.size(); t += 3) {
        for (int s = 0; s < samples_per_triangle; ++s) {
            double r1 = unit(rng), r2 = unit(rng);
            if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
            double x[3];
            for (int a = 0; a < 3; ++a)
                x[a] = p(from, from.indices[t], a) * (1 - r1 - r2) + p(from, from.indices[t + 1], a) * r1 +
                       p(from, from.indices[t + 2], a) * r2;
            double best = 1e300;
            for (size_t u = 0; u < to.indices.size(); u += 3) {
                double c[3][3];
                for (int k = 0; k < 3; ++k)
                    for (int a = 0; a < 3; ++a) c[k][a] = p(to, to.indices[u + size_t(k)], a);
                best = std::min(best, point_triangle_distance(x, c[0], c[1], c[2]));
            }
            worst = std::max(worst, best);
        }
    }
    return worst;
}

DistanceBound bound(const Mesh& from, const Mesh& to, double tolerance, std::span<const float> offsets = {}) {
    const TriangleTree tree(view(to), offsets);
    const std::vector<uint32_t> groups(from.triangle_count(), 0);
    return directed_distance(view(from), groups, 1, tree, tolerance)[0];
}

TEST(SurfaceDistance, PointToTriangleInEveryRegion) {
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0};
    const double above[3] = {0.25, 0.25, 2}, past_vertex[3] = {-3, -4, 0}, past_edge[3] = {0.5, -2, 0};
    const double past_hypotenuse[3] = {1, 1, 0};
    EXPECT_DOUBLE_EQ(point_triangle_distance(above, a, b, c), 2);
    EXPECT_DOUBLE_EQ(point_triangle_distance(past_vertex, a, b, c), 5);
    EXPECT_DOUBLE_EQ(point_triangle_distance(past_edge, a, b, c), 2);
    EXPECT_NEAR(point_triangle_distance(past_hypotenuse, a, b, c), std::sqrt(0.5), 1e-15);
    // A degenerate triangle is its longest edge.
    const double m[3] = {1, 0, 0}, far_end[3] = {3, 0, 0}, over_middle[3] = {2, 5, 0};
    EXPECT_DOUBLE_EQ(point_triangle_distance(over_middle, a, m, far_end), 5);
    EXPECT_DOUBLE_EQ(point_triangle_distance(over_middle, m, far_end, a), 5);
}

TEST(SurfaceDistance, AFlatCoarseGridOverAFineJitteredOneIsExactlyZeroBothWays) {
    auto flat = [](double, double) { return 0.0; };
    const Mesh coarse = height_grid(4, 1.0, flat), fine = height_grid(16, 1.0, flat, 0.3);
    const double tolerance = 1e-4;
    const DistanceBound down = bound(coarse, fine, tolerance), up = bound(fine, coarse, tolerance);
    EXPECT_LE(down.upper, tolerance);
    EXPECT_LE(up.upper, tolerance);
}

TEST(SurfaceDistance, ParallelPlanesAreTheirGapApart) {
    const Mesh low = height_grid(8, 1.0, [](double, double) { return 0.0; }, 0.3, 1);
    const Mesh high = height_grid(5, 1.0, [](double, double) { return 0.3; }, 0.3, 2);
    const DistanceBound b = bound(low, high, 1e-4);
    EXPECT_NEAR(b.lower, 0.3, 1e-6);
    EXPECT_GE(b.upper, 0.3 - 1e-6);
    EXPECT_LE(b.upper, 0.3 + 1e-4 + 1e-6);
}

TEST(SurfaceDistance, NeverBelowADenseSamplingOfACurvedSurfaceAndTightToItsTolerance) {
    // A wavy terrain against its coarser version, both ways: the bound holds and is tight.
    auto wave = [](double x, double y) { return 0.05 * std::sin(7 * x) * std::cos(5 * y) + 0.02 * x * y; };
    const Mesh coarse = height_grid(6, 1.0, wave, 0.2, 3), fine = height_grid(24, 1.0, wave, 0.2, 4);
    for (bool coarse_to_fine : {true, false}) {
        const Mesh& from = coarse_to_fine ? coarse : fine;
        const Mesh& to = coarse_to_fine ? fine : coarse;
        const double tolerance = 2e-4;
        const DistanceBound b = bound(from, to, tolerance);
        const double sampled = sampled_distance(from, to, coarse_to_fine ? 150 : 15, 5);
        EXPECT_GE(b.upper, sampled) << (coarse_to_fine ? "coarse to fine" : "fine to coarse");
        EXPECT_LE(b.upper, b.lower + tolerance + 1e-12);
        EXPECT_LE(b.upper, std::max(sampled, b.lower) + tolerance + 1e-12) << "the bound is loose";
    }
}

TEST(SurfaceDistance, NeverBelowADenseSamplingOfAClosedSurface) {
    // Spheres fold in every direction: the height field fails where the target turns away, and the
    // other two bounds must take over.
    const Mesh coarse = test::icosphere(1, 1.0f, 0.0f), fine = test::icosphere(3, 1.0f, 0.05f);
    for (bool coarse_to_fine : {true, false}) {
        const Mesh& from = coarse_to_fine ? coarse : fine;
        const Mesh& to = coarse_to_fine ? fine : coarse;
        const DistanceBound b = bound(from, to, 1e-3);
        const double sampled = sampled_distance(from, to, coarse_to_fine ? 150 : 6, 6);
        EXPECT_GE(b.upper, sampled);
        EXPECT_LE(b.upper, b.lower + 1e-3 + 1e-12);
    }
}

TEST(SurfaceDistance, WhereTheTargetEndsThePieceBeyondItCountsItsWholeReach) {
    // The target covers half of the source's square: the far edge of the source is 0.5 away.
    const Mesh whole = height_grid(4, 1.0, [](double, double) { return 0.0; });
    Mesh half = height_grid(4, 1.0, [](double, double) { return 0.0; });
    for (size_t v = 0; v < half.positions.size(); v += 3) half.positions[v] *= 0.5f;
    const DistanceBound b = bound(whole, half, 1e-4);
    EXPECT_NEAR(b.lower, 0.5, 1e-6);
    EXPECT_GE(b.upper, 0.5);
    EXPECT_LE(b.upper, 0.5 + 1e-4 + 1e-6);
}

// A flat grid with the triangles of the squares in [lo, hi)² removed: a hole, whose centre is
// (hi − lo)/2·size/n from the rest.
Mesh holed_grid(int n, int lo, int hi) {
    const Mesh whole = height_grid(n, 1.0, [](double, double) { return 0.0; });
    Mesh m = whole;
    m.indices.clear();
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            if (!(i >= lo && i < hi && j >= lo && j < hi))
                m.indices.insert(m.indices.end(), &whole.indices[6 * size_t(j * n + i)], &whole.indices[6 * size_t(j * n + i) + 6]);
    return m;
}

TEST(SurfaceDistance, AHoleUnderAPieceIsFoundEvenWithNoCornerOverIt) {
    // The source's corners all lie on the target; its farthest point is the hole's centre, 0.1 away.
    const Mesh source = height_grid(1, 1.0, [](double, double) { return 0.0; });
    const Mesh target = holed_grid(10, 4, 6);
    const DistanceBound b = bound(source, target, 1e-3);
    EXPECT_GE(b.upper, 0.1);
    EXPECT_LE(b.upper, 0.1 + 1e-3 + 1e-9);
}

TEST(SurfaceDistance, ADoubledPatchDoesNotHideAHole) {
    // Four squares of the target twice over: as much area as the hole, which a sum of covered areas
    // would miss. The pieces over the doubled patch must not count as covering anything.
    Mesh target = holed_grid(10, 4, 6);
    const size_t first = target.indices.size();
    for (size_t k = 0; k < 24; ++k) target.indices.push_back(target.indices[k]);
    ASSERT_EQ(target.indices.size(), first + 24);
    // One triangle, (0,0) (1,0) (1,1): half the hole and the whole doubled patch lie under it.
    Mesh source = height_grid(1, 1.0, [](double, double) { return 0.0; });
    source.indices.resize(3);
    const DistanceBound b = bound(source, target, 1e-3);
    EXPECT_GE(b.upper, 0.1);
}

TEST(SurfaceDistance, OffsetsAddToTheDistanceOfTheirTriangles) {
    const Mesh low = height_grid(4, 1.0, [](double, double) { return 0.0; });
    const Mesh high = height_grid(4, 1.0, [](double, double) { return 0.1; });
    const std::vector<float> offsets(high.triangle_count(), 0.25f);
    const DistanceBound b = bound(low, high, 1e-4, offsets);
    EXPECT_NEAR(b.lower, 0.35, 1e-6);
    EXPECT_LE(b.upper, 0.35 + 1e-4 + 1e-6);
}

TEST(SurfaceDistance, GroupsAreBoundedSeparately) {
    const Mesh grid = height_grid(4, 1.0, [](double x, double) { return x > 0.5 ? 0.2 : 0.0; });
    const Mesh flat = height_grid(4, 1.0, [](double, double) { return 0.0; });
    std::vector<uint32_t> groups(grid.triangle_count());
    for (uint32_t t = 0; t < groups.size(); ++t) {
        const float x = grid.positions[3 * size_t(grid.indices[3 * size_t(t)])];
        groups[t] = x < 0.5f ? 0 : 1;
    }
    const TriangleTree tree(view(flat), {});
    const std::vector<DistanceBound> b = directed_distance(view(grid), groups, 3, tree, 1e-4);
    EXPECT_LE(b[0].upper, 0.2 * 0.25 + 1e-4);  // the left group reaches at most a quarter of the ramp up
    EXPECT_NEAR(b[1].upper, 0.2, 1e-4 + 1e-6);
    EXPECT_EQ(b[2].upper, 0);  // no triangles
}

}  // namespace
}  // namespace strata
