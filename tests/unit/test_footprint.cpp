// An embedded mesh's footprint on a terrain grid (preprocess/footprint.h): its boundary loops, the outer
// ring in a fixed orientation, refusals of rings that cannot be stitched, and each cell's cover (NC, PC,
// CC) with rings on grid lines and corners, checked against a brute-force classification.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "preprocess/footprint.h"

namespace strata {
namespace {

GridPoint at(double x, double y) { return to_grid_point({x, y}); }

// A mesh from 2D points (z = 0) and triangles.
Mesh mesh_of(const std::vector<glm::dvec2>& points, const std::vector<uint32_t>& triangles) {
    Mesh mesh;
    for (const glm::dvec2& p : points) mesh.positions.insert(mesh.positions.end(), {float(p.x), float(p.y), 0.0f});
    mesh.indices = triangles;
    return mesh;
}

// An n × n grid of quads spanning [x0, x0 + n·step]², two counter-clockwise triangles each.
Mesh patch(double x0, double y0, int n, double step) {
    std::vector<glm::dvec2> points;
    std::vector<uint32_t> triangles;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) points.push_back({x0 + i * step, y0 + j * step});
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n) + 1, d = c + 1;
            triangles.insert(triangles.end(), {a, b, d, a, d, c});
        }
    return mesh_of(points, triangles);
}

// A fan from the ring's centroid: its boundary is the ring, whatever the ring's shape.
Mesh fan(const std::vector<glm::dvec3>& ring) {
    Mesh mesh;
    glm::dvec3 centre(0);
    for (const glm::dvec3& p : ring) centre += p / double(ring.size());
    for (const glm::dvec3& p : ring) mesh.positions.insert(mesh.positions.end(), {float(p.x), float(p.y), float(p.z)});
    mesh.positions.insert(mesh.positions.end(), {float(centre.x), float(centre.y), float(centre.z) + 0.5f});
    const uint32_t n = uint32_t(ring.size());
    for (uint32_t i = 0; i < n; ++i) mesh.indices.insert(mesh.indices.end(), {n, i, (i + 1) % n});
    return mesh;
}

const auto kIdentity = [](const glm::dvec3& p) { return glm::dvec2(p.x, p.y); };

std::set<std::pair<int64_t, int64_t>> touched(GridPoint a, GridPoint b, int64_t size) {
    std::set<std::pair<int64_t, int64_t>> cells;
    cells_touched(a, b, size, [&](int64_t x, int64_t y) { EXPECT_TRUE(cells.emplace(x, y).second) << "visited twice"; });
    return cells;
}

TEST(Footprint, SegmentsTouchEveryClosedCellTheyMeet) {
    using Cells = std::set<std::pair<int64_t, int64_t>>;
    EXPECT_EQ(touched(at(0.2, 0.3), at(0.7, 0.9), 1), (Cells{{0, 0}}));
    // Along a grid line: the cells on both sides.
    EXPECT_EQ(touched(at(1.2, 2), at(1.8, 2), 1), (Cells{{1, 1}, {1, 2}}));
    // Through a corner: all four around it.
    EXPECT_EQ(touched(at(0.5, 0.5), at(1.5, 1.5), 1), (Cells{{0, 0}, {0, 1}, {1, 0}, {1, 1}}));
    // Vertical, ending on a line: the cells it reaches, and those across the line at its end.
    EXPECT_EQ(touched(at(2.5, 0.5), at(2.5, 2), 1), (Cells{{2, 0}, {2, 1}, {2, 2}}));
    // Cells of 4 steps; a shallow diagonal crossing one line between cells.
    EXPECT_EQ(touched(at(1, 1), at(7, 3), 4), (Cells{{0, 0}, {1, 0}}));
    EXPECT_EQ(touched(at(7, 3), at(1, 1), 4), (Cells{{0, 0}, {1, 0}}));  // either way round
}

TEST(Footprint, BoundaryLoopsFollowTheTrianglesAndIgnoreSeams) {
    Mesh mesh = patch(0, 0, 2, 1);
    std::vector<std::vector<uint32_t>> loops = boundary_loops(mesh, "patch");
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_EQ(loops[0].size(), 8u);
    // Counter-clockwise triangles run counter-clockwise along their outer boundary: 0 → 1 → 2 → 5 …
    EXPECT_EQ(std::vector<uint32_t>(loops[0].begin(), loops[0].begin() + 4), (std::vector<uint32_t>{0, 1, 2, 5}));
    // A seam: the centre vertex duplicated (another UV) for two of its triangles is still one vertex.
    mesh.positions.insert(mesh.positions.end(), {1.0f, 1.0f, 0.0f});
    for (size_t t = 0; t < 6; ++t)
        if (mesh.indices[t] == 4) mesh.indices[t] = 9;
    loops = boundary_loops(mesh, "patch");
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_EQ(loops[0].size(), 8u);
}

TEST(Footprint, TwoLoopsTouchingInAPointAreAmbiguous) {
    const Mesh bowtie = mesh_of({{0, 0}, {1, 0}, {1, 1}, {2, 1}, {2, 2}}, {0, 1, 2, 2, 3, 4});
    try {
        boundary_loops(bowtie, "bowtie.ply");
        FAIL() << "a bowtie's boundary was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("bowtie.ply: boundary vertex 2"), std::string::npos) << e.what();
    }
}

TEST(Footprint, TheOuterRingRunsCounterClockwiseInRasterSpaceWhicheverWayTheMeshRuns) {
    Mesh mesh = patch(2.25, 3.5, 3, 0.5);
    Footprint footprint = make_footprint(mesh, kIdentity, 10, 10, "patch");
    ASSERT_EQ(footprint.points.size(), 12u);
    for (size_t i = 0; i + 2 < footprint.points.size(); ++i)
        EXPECT_GE(orientation(footprint.points[i], footprint.points[i + 1], footprint.points[i + 2]), 0);
    EXPECT_EQ(footprint.inner_loops, 0u);
    // Flipped triangles (clockwise), or a raster whose rows run the other way: the same orientation.
    for (size_t t = 0; t < mesh.indices.size(); t += 3) std::swap(mesh.indices[t + 1], mesh.indices[t + 2]);
    footprint = make_footprint(mesh, kIdentity, 10, 10, "patch");
    for (size_t i = 0; i + 2 < footprint.points.size(); ++i)
        EXPECT_GE(orientation(footprint.points[i], footprint.points[i + 1], footprint.points[i + 2]), 0);
    footprint = make_footprint(mesh, [](const glm::dvec3& p) { return glm::dvec2(p.x, 9 - p.y); }, 10, 10, "patch");
    for (size_t i = 0; i + 2 < footprint.points.size(); ++i)
        EXPECT_GE(orientation(footprint.points[i], footprint.points[i + 1], footprint.points[i + 2]), 0);
}

TEST(Footprint, AHoleInTheMeshIsAnInnerLoop) {
    // A 3 × 3 patch without its centre quad.
    Mesh mesh = patch(1, 1, 3, 1);
    mesh.indices.erase(mesh.indices.begin() + 4 * 6, mesh.indices.begin() + 5 * 6);
    const Footprint footprint = make_footprint(mesh, kIdentity, 10, 10, "ring");
    EXPECT_EQ(footprint.points.size(), 12u);
    EXPECT_EQ(footprint.inner_loops, 1u);
}

void expect_refused(const Mesh& mesh, const std::string& message, int64_t size = 10) {
    try {
        make_footprint(mesh, kIdentity, size, size, "site.ply");
        FAIL() << "accepted; expected: " << message;
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("site.ply: " + message), std::string::npos) << e.what() << "; expected: " << message;
    }
}

TEST(Footprint, RingsThatCannotBeStitchedAreRefusedNamingTheFile) {
    // Closed: a tetrahedron.
    Mesh tetrahedron = mesh_of({{1, 1}, {3, 1}, {2, 3}}, {0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3});
    tetrahedron.positions.insert(tetrahedron.positions.end(), {2.0f, 2.0f, 1.0f});
    expect_refused(tetrahedron, "the mesh has no open boundary");
    // Crossing itself seen from above: a quad whose far corners are swapped.
    expect_refused(fan({{1, 1, 0}, {4, 1, 0}, {1, 3, 0}, {3, 4, 0}}), "the boundary crosses or touches itself");
    // Touching itself: a vertex on another edge.
    expect_refused(fan({{1, 1, 0}, {5, 1, 0}, {5, 3, 0}, {3, 1, 0}, {1, 3, 0}}), "the boundary crosses or touches itself");
    // A vertical boundary edge: two vertices on one point of the ground.
    expect_refused(fan({{1, 1, 0}, {4, 1, 0}, {4, 4, 0}, {1, 4, 0}, {1, 4, 1}}), "two boundary vertices fall on the same point");
    // A vertical wall: no area on the ground.
    Mesh wall;
    wall.positions = {1, 1, 0, 3, 1, 0, 3, 1, 2};
    wall.indices = {0, 1, 2};
    expect_refused(wall, "the mesh's boundary encloses no area");
    // Outside the raster.
    expect_refused(patch(8, 8, 2, 1), "the mesh reaches outside the terrain's raster");
    // Two pieces.
    Mesh two = patch(1, 1, 1, 1);
    const Mesh other = patch(5, 5, 1, 1);
    for (const uint32_t i : other.indices) two.indices.push_back(i + 4);
    two.positions.insert(two.positions.end(), other.positions.begin(), other.positions.end());
    expect_refused(two, "the mesh has separate pieces");
}

// Brute force: a cell is PC when any ring edge meets its closed square (an end inside, or an edge
// crossing one of its sides), CC when not PC and its centre is inside the ring.
CellCover brute_cover(const std::vector<GridPoint>& ring, int64_t x, int64_t y, int64_t size, int64_t last) {
    const int64_t one = kGridPointOne;
    const int64_t x0 = x * size * one, y0 = y * size * one;
    const int64_t x1 = std::min((x + 1) * size, last) * one, y1 = std::min((y + 1) * size, last) * one;
    const GridPoint corners[4] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
    auto on_or_in = [&](GridPoint p) { return p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1; };
    auto meet = [](GridPoint a, GridPoint b, GridPoint c, GridPoint d) {
        const int o1 = orientation(a, b, c), o2 = orientation(a, b, d), o3 = orientation(c, d, a), o4 = orientation(c, d, b);
        auto within = [](GridPoint p, GridPoint q, GridPoint r) {
            return std::min(p.x, q.x) <= r.x && r.x <= std::max(p.x, q.x) && std::min(p.y, q.y) <= r.y && r.y <= std::max(p.y, q.y);
        };
        if (o1 * o2 < 0 && o3 * o4 < 0) return true;
        return (o1 == 0 && within(a, b, c)) || (o2 == 0 && within(a, b, d)) || (o3 == 0 && within(c, d, a)) || (o4 == 0 && within(c, d, b));
    };
    for (size_t i = 0; i < ring.size(); ++i) {
        const GridPoint a = ring[i], b = ring[(i + 1) % ring.size()];
        if (on_or_in(a)) return CellCover::partly;
        for (int k = 0; k < 4; ++k)
            if (meet(a, b, corners[k], corners[(k + 1) % 4])) return CellCover::partly;
    }
    // Centre inside: crossing number of a ray towards +x.
    const double cx = (double(x0) + double(x1)) / 2, cy = (double(y0) + double(y1)) / 2;
    bool in = false;
    for (size_t i = 0; i < ring.size(); ++i) {
        const GridPoint a = ring[i], b = ring[(i + 1) % ring.size()];
        if ((double(a.y) > cy) == (double(b.y) > cy)) continue;
        const double t = (cy - double(a.y)) / (double(b.y) - double(a.y));
        if (double(a.x) + t * (double(b.x) - double(a.x)) > cx) in = !in;
    }
    return in ? CellCover::whole : CellCover::none;
}

void expect_covers_match_brute_force(const Footprint& footprint, int64_t size, int64_t raster) {
    const CellCovers covers = classify_cells(footprint.points, size, raster, raster);
    const int64_t cells = (raster - 1 + size - 1) / size;
    size_t partly = 0, whole = 0;
    for (int64_t y = 0; y < cells; ++y)
        for (int64_t x = 0; x < cells; ++x) {
            const CellCover expected = brute_cover(footprint.points, x, y, size, raster - 1);
            ASSERT_EQ(int(covers.at(x, y)), int(expected)) << "cell " << x << ", " << y << " of size " << size;
            partly += expected == CellCover::partly;
            whole += expected == CellCover::whole;
        }
    EXPECT_GT(partly, 0u);
}

TEST(Footprint, CellsOnTheRingArePartlyCoveredAndThoseInsideWhollyEvenOnGridLines) {
    // Off the grid lines: a 3 × 3 square from 1.5 to 4.5, cells of one step.
    Footprint square = make_footprint(patch(1.5, 1.5, 3, 1), kIdentity, 10, 10, "square");
    CellCovers covers = classify_cells(square.points, 1, 10, 10);
    for (int64_t y = 0; y < 9; ++y)
        for (int64_t x = 0; x < 9; ++x) {
            const bool ring = (x == 1 || x == 4 || y == 1 || y == 4) && x >= 1 && x <= 4 && y >= 1 && y <= 4;
            const bool in = x >= 2 && x <= 3 && y >= 2 && y <= 3;
            EXPECT_EQ(int(covers.at(x, y)), int(ring ? CellCover::partly : in ? CellCover::whole : CellCover::none)) << x << ", " << y;
        }
    // On the grid lines and corners: from 2 to 5; every cell the ring bounds is PC (inside
    // and out), only the centre cell is CC.
    square = make_footprint(patch(2, 2, 3, 1), kIdentity, 10, 10, "square");
    covers = classify_cells(square.points, 1, 10, 10);
    for (int64_t y = 0; y < 9; ++y)
        for (int64_t x = 0; x < 9; ++x) {
            const auto by_ring = [](int64_t v) { return v == 1 || v == 2 || v == 4 || v == 5; };
            const bool near = x >= 1 && x <= 5 && y >= 1 && y <= 5;
            const CellCover expected = near && (by_ring(x) || by_ring(y)) ? CellCover::partly
                                       : x == 3 && y == 3                  ? CellCover::whole
                                                                           : CellCover::none;
            EXPECT_EQ(int(covers.at(x, y)), int(expected)) << x << ", " << y;
        }
    expect_covers_match_brute_force(square, 1, 10);
    expect_covers_match_brute_force(square, 2, 10);
}

TEST(Footprint, CoversOfRandomRingsMatchABruteForceClassification) {
    std::mt19937 random(3);
    for (int trial = 0; trial < 30; ++trial) {
        // A star-shaped ring (simple), some vertices snapped onto grid lines and corners.
        const int n = 5 + int(random() % 40);
        const glm::dvec2 centre(20 + (random() % 100) / 10.0, 20 + (random() % 100) / 10.0);
        std::vector<glm::dvec2> points{centre};
        std::vector<uint32_t> triangles;
        for (int i = 0; i < n; ++i) {
            const double angle = 2 * M_PI * i / n, radius = 3 + (random() % 1400) / 100.0;
            glm::dvec2 p = centre + radius * glm::dvec2(std::cos(angle), std::sin(angle));
            if (random() % 3 == 0) p.x = std::round(p.x);
            if (random() % 3 == 0) p.y = std::round(p.y);
            points.push_back(p);
            triangles.insert(triangles.end(), {0, uint32_t(1 + i), uint32_t(1 + (i + 1) % n)});
        }
        Footprint footprint;
        try {
            footprint = make_footprint(mesh_of(points, triangles), kIdentity, 48, 48, "star");
        } catch (const InputError&) {
            continue;  // snapping made it touch itself: refused, as it should be
        }
        for (const int64_t size : {1, 2, 4, 8}) expect_covers_match_brute_force(footprint, size, 48);
    }
}

}  // namespace
}  // namespace strata
