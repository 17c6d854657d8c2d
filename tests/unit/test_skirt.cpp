// The skirt (preprocess/skirt.h): the ground between an embedding's zone and its footprint, cut along the
// ring at the raster's finest level. Whatever the ring (on grid lines, through grid corners, along
// them, wiggling across cells), the skirt and the footprint tile the zone: every triangle turns the right
// way, the areas add up, and every edge is shared with exactly one reverse edge except along the zone's
// border, where the terrain's cells take over.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <set>

#include "preprocess/skirt.h"

namespace strata {
namespace {

Mesh fan(const std::vector<glm::dvec2>& ring) {
    Mesh mesh;
    glm::dvec2 centre(0);
    for (const glm::dvec2& p : ring) centre += p / double(ring.size());
    for (const glm::dvec2& p : ring) mesh.positions.insert(mesh.positions.end(), {float(p.x), float(p.y), 0.0f});
    mesh.positions.insert(mesh.positions.end(), {float(centre.x), float(centre.y), 1.0f});
    const uint32_t n = uint32_t(ring.size());
    for (uint32_t i = 0; i < n; ++i) mesh.indices.insert(mesh.indices.end(), {n, i, (i + 1) % n});
    return mesh;
}

Footprint footprint_of(const std::vector<glm::dvec2>& ring, int64_t size) {
    return make_footprint(fan(ring), [](const glm::dvec3& p) { return glm::dvec2(p.x, p.y); }, size, size, "site");
}

double cross(GridPoint a, GridPoint b, GridPoint c) {
    return (double(b.x - a.x) * double(c.y - a.y) - double(b.y - a.y) * double(c.x - a.x)) / double(kGridPointOne) / double(kGridPointOne);
}

// Checks the tiling; returns the number of skirt triangles.
size_t expect_tiles_the_zone(const Footprint& footprint, int64_t zone_size, int64_t raster) {
    const CellCovers zone = classify_cells(footprint.points, zone_size, raster, raster);
    const Skirt skirt = build_skirt(footprint, zone, raster, raster, "site");
    const auto& v = skirt.vertices;
    // Orientation, and the areas.
    double skirt_area = 0;
    for (size_t t = 0; t < skirt.triangles.size(); t += 3) {
        const double a = cross(v[skirt.triangles[t]].at, v[skirt.triangles[t + 1]].at, v[skirt.triangles[t + 2]].at);
        EXPECT_GE(a, 0) << "triangle " << t / 3 << " turns the wrong way";
        skirt_area += a / 2;
    }
    double ring_area = 0;
    for (size_t i = 0; i < footprint.points.size(); ++i)
        ring_area += cross({0, 0}, footprint.points[i], footprint.points[(i + 1) % footprint.points.size()]) / 2;
    std::set<std::pair<int64_t, int64_t>> zone_cells;
    for (int64_t zy = zone.first_y; zy < zone.first_y + zone.height; ++zy)
        for (int64_t zx = zone.first_x; zx < zone.first_x + zone.width; ++zx)
            if (zone.at(zx, zy) != CellCover::none)
                for (int64_t y = zy * zone_size; y < std::min((zy + 1) * zone_size, raster - 1); ++y)
                    for (int64_t x = zx * zone_size; x < std::min((zx + 1) * zone_size, raster - 1); ++x) zone_cells.emplace(x, y);
    const double snapping = 1e-5 * double(v.size());  // crossings are rounded to a millionth of a cell
    EXPECT_NEAR(skirt_area + ring_area, double(zone_cells.size()), snapping);
    // Edges: the skirt's, and the ring's (split at its crossings) as the footprint's side of them.
    std::map<std::pair<uint32_t, uint32_t>, int> edges;
    for (size_t t = 0; t < skirt.triangles.size(); t += 3)
        for (int k = 0; k < 3; ++k) ++edges[{skirt.triangles[t + k], skirt.triangles[t + (k + 1) % 3]}];
    const uint32_t n = uint32_t(footprint.points.size());
    for (uint32_t e = 0; e < n; ++e) {
        uint32_t from = e;
        for (const uint32_t x : skirt.crossings[e]) ++edges[{from, x}], from = x;
        ++edges[{from, (e + 1) % n}];
    }
    // Unmatched half-edges must be the zone's border, counter-clockwise around it, between samples.
    std::set<std::pair<std::pair<int64_t, int64_t>, std::pair<int64_t, int64_t>>> border;
    for (const auto& [x, y] : zone_cells) {
        auto out = [&](int64_t cx, int64_t cy) { return !zone_cells.count({cx, cy}); };
        if (out(x, y - 1)) border.insert({{x, y}, {x + 1, y}});
        if (out(x + 1, y)) border.insert({{x + 1, y}, {x + 1, y + 1}});
        if (out(x, y + 1)) border.insert({{x + 1, y + 1}, {x, y + 1}});
        if (out(x - 1, y)) border.insert({{x, y + 1}, {x, y}});
    }
    size_t open = 0;
    for (const auto& [edge, count] : edges) {
        const auto reverse = edges.find({edge.second, edge.first});
        const int back = reverse == edges.end() ? 0 : reverse->second;
        EXPECT_LE(count, 1) << "edge " << edge.first << "→" << edge.second << " used " << count << " times";
        if (back == count) continue;
        const SkirtVertex &a = v[edge.first], &b = v[edge.second];
        const bool on_border = a.kind == SkirtVertex::Kind::sample && b.kind == SkirtVertex::Kind::sample && border.count({{a.a, a.b}, {b.a, b.b}});
        EXPECT_TRUE(on_border) << "open edge " << edge.first << " (" << a.at.x << ", " << a.at.y << ") → " << edge.second << " (" << b.at.x << ", "
                               << b.at.y << ") inside the zone";
        open += on_border;
    }
    EXPECT_EQ(open, border.size()) << "the zone's border is not the skirt's";
    return skirt.triangles.size() / 3;
}

TEST(Skirt, TilesTheZoneAroundASquareOffTheGridLines) {
    const Footprint square = footprint_of({{4.5, 4.5}, {9.5, 4.5}, {9.5, 9.5}, {4.5, 9.5}}, 20);
    EXPECT_GT(expect_tiles_the_zone(square, 4, 20), 0u);
    expect_tiles_the_zone(square, 8, 20);
}

TEST(Skirt, TilesTheZoneWhenTheRingRunsAlongGridLinesAndThroughCorners) {
    // On the lines and corners (cells on both sides are touched).
    expect_tiles_the_zone(footprint_of({{4, 4}, {9, 4}, {9, 9}, {4, 9}}, 20), 4, 20);
    // A diagonal through grid corners, and a vertex on a corner.
    expect_tiles_the_zone(footprint_of({{4, 4}, {10, 10}, {4, 10}}, 20), 4, 20);
    expect_tiles_the_zone(footprint_of({{5, 4.5}, {9.25, 6}, {8, 9}, {5, 8}}, 20), 2, 20);
    // Collinear vertices along a line, and a vertex on a line with its edges on one side of it.
    expect_tiles_the_zone(footprint_of({{4.5, 4}, {6, 4}, {7.5, 4}, {9, 4}, {8.5, 6}, {6, 8.3}, {4, 6}}, 20), 4, 20);
}

// The zone tiles around 40 rings that `ring_of` makes (those that rounding makes touch themselves
// skipped: at least 20 are tried), with zone cells of each of `zones` raster steps.
void expect_random_rings_tile(uint32_t seed, int64_t raster, std::initializer_list<int64_t> zones,
                              const std::function<std::vector<glm::dvec2>(std::mt19937&)>& ring_of) {
    std::mt19937 random(seed);
    size_t tried = 0;
    for (int trial = 0; trial < 40 && !::testing::Test::HasFailure(); ++trial) {
        Footprint footprint;
        try {
            footprint = footprint_of(ring_of(random), raster);
        } catch (const InputError&) {
            continue;
        }
        ++tried;
        for (const int64_t zone : zones) expect_tiles_the_zone(footprint, zone, raster);
    }
    EXPECT_GT(tried, 20u);
}

// A star-shaped ring of n vertices about `centre`, at radii `reach` draws.
template <typename Reach>
std::vector<glm::dvec2> star(int n, glm::dvec2 centre, Reach&& reach) {
    std::vector<glm::dvec2> ring;
    for (int i = 0; i < n; ++i) {
        const double angle = 2 * M_PI * i / n;
        ring.push_back(centre + reach() * glm::dvec2(std::cos(angle), std::sin(angle)));
    }
    return ring;
}

TEST(Skirt, TilesTheZoneOfWigglyRings) {
    // Detail below the cell size, some vertices on grid lines and corners.
    expect_random_rings_tile(11, 40, {4, 16}, [](std::mt19937& random) {
        const int n = 8 + int(random() % 120);
        const glm::dvec2 centre(16 + (random() % 100) / 37.0, 16 + (random() % 100) / 41.0);
        std::vector<glm::dvec2> ring = star(n, centre, [&] { return 3 + (random() % 900) / 100.0; });
        for (glm::dvec2& p : ring) {
            if (random() % 4 == 0) p.x = std::round(p.x);
            if (random() % 4 == 0) p.y = std::round(p.y);
        }
        return ring;
    });
}

TEST(Skirt, TilesTheZoneAroundARingInsideOneCell) {
    // A mesh smaller than a raster cell: the cell is cut around the hole it leaves.
    EXPECT_GT(expect_tiles_the_zone(footprint_of({{5.2, 5.2}, {5.8, 5.2}, {5.5, 5.8}}, 20), 4, 20), 8u);
    expect_tiles_the_zone(footprint_of({{5.2, 5.2}, {5.8, 5.2}, {5.5, 5.8}}, 20), 2, 20);
    // Ties for the westmost and the eastmost vertex (vertical runs at both ends), and a notch.
    expect_tiles_the_zone(footprint_of({{6.1, 6.1}, {6.5, 6.1}, {6.9, 6.1}, {6.9, 6.5}, {6.9, 6.9}, {6.5, 6.3}, {6.1, 6.9}, {6.1, 6.5}}, 20), 4, 20);
    // Wiggly rings inside the cell from (9, 9) to (10, 10), some almost filling it.
    expect_random_rings_tile(5, 20, {2, 8}, [](std::mt19937& random) {
        const int n = 3 + int(random() % 60);
        const glm::dvec2 centre(9.5 + (random() % 100) / 1000.0, 9.5 + (random() % 100) / 1000.0);
        return star(n, centre, [&] { return 0.05 + (random() % 340) / 1000.0; });
    });
}

}  // namespace
}  // namespace strata
