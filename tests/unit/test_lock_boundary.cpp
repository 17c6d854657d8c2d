// Builds that lock the model's open boundary (BuildSettings::lock_boundary, for meshes embedded in a
// terrain): every level has the finest level's boundary, decoded to the same floats, whatever the blocks
// that cut it; and builds without the option are the bytes they were before it existed.
#include "preprocess/build_cubes.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/mesh_io.h"
#include "tests/support/test_meshes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <set>

namespace strata {
namespace {

using Point = std::array<uint32_t, 3>;  // a position's float bits
using Edge = std::pair<Point, Point>;   // the lesser end first

Point bits_of(const float* x) {
    Point p;
    for (int a = 0; a < 3; ++a) {
        const float v = x[a] + 0.0f;  // −0 as +0
        std::memcpy(&p[size_t(a)], &v, 4);
    }
    return p;
}

Edge edge_of(const Point& a, const Point& b) { return a < b ? Edge{a, b} : Edge{b, a}; }

// A level's open boundary as drawn: the edges one triangle uses, ends welded by their decoded floats.
struct Boundary {
    std::set<Edge> edges;
    std::set<Point> points;
};

// Every level's boundary, coarsest first, counted the slow way: all of a level's edges at once.
std::vector<Boundary> boundaries(const std::filesystem::path& model) {
    HlodFile file(model);
    const HlodHeader& h = file.header();
    std::vector<std::map<Edge, int>> uses(h.max_level + 1);
    for (const HlodNode& n : file.nodes()) {
        const CubeData cube = file.read_cube(n);
        const uint32_t cell[3] = {n.i, n.j, n.k};
        std::vector<Point> point(cube.vertex_count());
        for (uint32_t v = 0; v < cube.vertex_count(); ++v) {
            float x[3];
            for (int a = 0; a < 3; ++a) x[a] = decode_coordinate(h, a, n.level, cell[a], cube.vertices.positions[3 * v + size_t(a)]);
            point[v] = bits_of(x);
        }
        for (size_t t = 0; t < cube.indices.size(); t += 3) {
            const Point* c[3] = {&point[cube.indices[t]], &point[cube.indices[t + 1]], &point[cube.indices[t + 2]]};
            if (*c[0] == *c[1] || *c[1] == *c[2] || *c[0] == *c[2]) continue;
            for (int e = 0; e < 3; ++e) ++uses[n.level][edge_of(*c[e], *c[(e + 1) % 3])];
        }
    }
    std::vector<Boundary> out(h.max_level + 1);
    for (uint32_t l = 0; l <= h.max_level; ++l)
        for (const auto& [e, count] : uses[l])
            if (count == 1) out[l].edges.insert(e), out[l].points.insert(e.first), out[l].points.insert(e.second);
    return out;
}

// The input's boundary, welded by position.
Boundary input_boundary(const Mesh& mesh) {
    std::map<Edge, int> uses;
    for (size_t t = 0; t < mesh.indices.size(); t += 3)
        for (int c = 0; c < 3; ++c)
            ++uses[edge_of(bits_of(&mesh.positions[3 * size_t(mesh.indices[t + c])]),
                           bits_of(&mesh.positions[3 * size_t(mesh.indices[t + (c + 1) % 3])]))];
    Boundary b;
    for (const auto& [e, count] : uses)
        if (count == 1) b.edges.insert(e), b.points.insert(e.first), b.points.insert(e.second);
    return b;
}

// The bundled scan (closed) with holes cut where level 3's blocks of 4 cubes meet (cubes 2 and 6 of 8
// a side: x = O + L_c/4 and 3L_c/4; level 2's at L_c/2), so that their rims cross block borders: the
// triangles whose barycenters lie within 3 % of the model's size of a vertex on each such plane.
Mesh holed_scan() {
    Mesh mesh = read_mesh(std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "bunny.off");
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (size_t v = 0; v < mesh.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], mesh.positions[3 * v + a]), hi[a] = std::max(hi[a], mesh.positions[3 * v + a]);
    const float size = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    std::vector<std::array<float, 3>> centres;
    for (const auto& [axis, at] : std::vector<std::pair<int, float>>{{0, 0.25f}, {0, 0.75f}, {1, 0.25f}, {1, 0.5f}, {1, 0.75f}, {2, 0.25f}})
        for (size_t v = 0; v < mesh.vertex_count(); ++v)
            if (std::fabs(mesh.positions[3 * v + size_t(axis)] - (lo[axis] + at * size)) < 0.002f * size) {
                centres.push_back({mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]});
                break;
            }
    std::vector<uint32_t> kept;
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        bool in_hole = false;
        for (const auto& c : centres) {
            double d = 0;
            for (int a = 0; a < 3; ++a) {
                double b = 0;
                for (int k = 0; k < 3; ++k) b += mesh.positions[3 * size_t(mesh.indices[t + k]) + a] / 3.0;
                d += (b - c[size_t(a)]) * (b - c[size_t(a)]);
            }
            in_hole |= std::sqrt(d) < 0.03 * size;
        }
        if (!in_hole) kept.insert(kept.end(), &mesh.indices[t], &mesh.indices[t] + 3);
    }
    mesh.indices = kept;
    return mesh;
}

// Level 3's boundary points used by triangles of several blocks, and among them those with a block whose
// triangles there hold no boundary edge (that block cannot tell it is on the boundary: only its
// neighbours' edges say so).
std::pair<size_t, size_t> boundary_points_across_blocks(const Mesh& mesh, const HlodHeader& h) {
    build::Frame f{};
    for (int a = 0; a < 3; ++a) f.origin[a] = h.origin[a];
    f.root_size = h.root_size, f.max_level = h.max_level, f.block = h.block_size;
    std::map<Edge, std::vector<build::CubeKey>> edge_blocks;
    std::map<Point, std::set<build::CubeKey>> point_blocks;
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        const float* c[3];
        for (int k = 0; k < 3; ++k) c[k] = &mesh.positions[3 * size_t(mesh.indices[t + k])];
        const build::CubeKey block = f.block_of(build::cell_of(f, build::barycenter(c[0], c[1], c[2]), f.max_level));
        for (int k = 0; k < 3; ++k) {
            edge_blocks[edge_of(bits_of(c[k]), bits_of(c[(k + 1) % 3]))].push_back(block);
            point_blocks[bits_of(c[k])].insert(block);
        }
    }
    std::map<Point, std::set<build::CubeKey>> blocks_with_an_edge;
    for (const auto& [e, blocks] : edge_blocks)
        if (blocks.size() == 1) blocks_with_an_edge[e.first].insert(blocks[0]), blocks_with_an_edge[e.second].insert(blocks[0]);
    size_t shared = 0, unseen = 0;
    for (const auto& [p, with_edge] : blocks_with_an_edge) {
        shared += point_blocks[p].size() > 1;
        unseen += point_blocks[p].size() > with_edge.size();
    }
    return {shared, unseen};
}

BuildSettings locked(int levels) {
    BuildSettings s;
    s.levels = levels;
    s.lock_boundary = true;
    return s;
}

// Every level's boundary is level L's, edge for edge and float for float, and level L's is the input's;
// the build locked the input's boundary points, no fewer and no more.
void expect_locked_at_every_level(const std::filesystem::path& model, const Mesh& input, const BuildReport& report) {
    const std::vector<Boundary> b = boundaries(model);
    const Boundary& finest = b.back();
    const Boundary given = input_boundary(input);
    EXPECT_EQ(finest.edges.size(), given.edges.size()) << "level L lost or gained boundary edges";
    EXPECT_EQ(report.boundary_points, given.points.size());
    for (size_t l = 0; l + 1 < b.size(); ++l) {
        EXPECT_EQ(b[l].points, finest.points) << "level " << l << "'s boundary vertices decode elsewhere";
        EXPECT_EQ(b[l].edges, finest.edges) << "level " << l << "'s boundary edges differ";
    }
    EXPECT_TRUE(verify_hlod(HlodFile(model)).boundary_locked);
}

TEST(LockBoundary, EveryLevelDrawsTheFinestLevelsBoundaryBitForBitAcrossBlocks) {
    test::TempDir dir;
    const Mesh scan = holed_scan();
    ASSERT_GT(input_boundary(scan).edges.size(), 100u);
    const BuildReport report = build_hlod(Mesh(scan), dir / "locked.hlod", locked(3), "bunny.off");
    ASSERT_EQ(report.max_level, 3u);
    const HlodFile file(dir / "locked.hlod");
    EXPECT_TRUE(file.header().flags & kLockedBoundary);
    const auto [shared, unseen] = boundary_points_across_blocks(scan, file.header());
    EXPECT_GE(shared, 8u) << "the holes' rims must cross block borders";
    EXPECT_GT(unseen, 0u) << "some boundary point must be used by a block that holds none of its boundary edges";
    expect_locked_at_every_level(dir / "locked.hlod", scan, report);

    // Without the option the coarse levels simplify the rims: the same check fails.
    BuildSettings free_settings = locked(3);
    free_settings.lock_boundary = false;
    build_hlod(Mesh(scan), dir / "free.hlod", free_settings, "bunny.off");
    const std::vector<Boundary> free = boundaries(dir / "free.hlod");
    EXPECT_NE(free[0].points, free.back().points);
    EXPECT_NE(free[2].points, free.back().points);
    EXPECT_FALSE(verify_hlod(HlodFile(dir / "free.hlod")).boundary_locked);
}

// Ten per cent of the triangles kept per level: the root holds a few hundred triangles, and still every
// one of the holes' rims, vertex for vertex.
TEST(LockBoundary, TheBoundarySurvivesSimplificationToAFewHundredTriangles) {
    test::TempDir dir;
    const Mesh scan = holed_scan();
    BuildSettings s = locked(3);
    s.ratio = 0.1f;
    const BuildReport report = build_hlod(Mesh(scan), dir / "coarse.hlod", s, "bunny.off");
    EXPECT_LT(report.levels.back().triangles, 500u);
    EXPECT_GT(report.levels.back().triangles, 100u);
    expect_locked_at_every_level(dir / "coarse.hlod", scan, report);
}

// Colours, UVs and seams: the copies of a boundary vertex are one point, locked together. The seamed
// grid's seam meets the boundary at both its ends.
TEST(LockBoundary, SeamCopiesOnTheBoundaryAreOnePoint) {
    test::TempDir dir;
    const Mesh seam = test::seamed_grid(96, 36), grid = test::colored_grid(120);
    expect_locked_at_every_level(dir / "seam.hlod", seam, build_hlod(Mesh(seam), dir / "seam.hlod", locked(2), "seam"));
    expect_locked_at_every_level(dir / "grid.hlod", grid, build_hlod(Mesh(grid), dir / "grid.hlod", locked(2), "grid"));
}

// One level (L = 0): no simplifying stage, the root's one job finds the boundary.
TEST(LockBoundary, AModelOfOneLevelLocksItsBoundaryToo) {
    test::TempDir dir;
    const Mesh grid = test::colored_grid(40);
    expect_locked_at_every_level(dir / "grid.hlod", grid, build_hlod(Mesh(grid), dir / "grid.hlod", locked(0), "grid"));
}

TEST(LockBoundary, OutputIsByteIdenticalAtAnyThreadCount) {
    test::TempDir dir;
    BuildSettings s = locked(3);
    s.threads = 1;
    build_hlod(holed_scan(), dir / "one.hlod", s, "bunny.off");
    s.threads = 4;
    build_hlod(holed_scan(), dir / "four.hlod", s, "bunny.off");
    EXPECT_EQ(test::file_bytes(dir / "one.hlod"), test::file_bytes(dir / "four.hlod"));
}

// FORMAT.md §6's claim, checked rather than trusted: q = q0·2^l decodes to the float q0 does at level 0,
// at every level, for any origin and root size, also where f32(q) rounds (q past 2^24).
TEST(LockBoundary, ALevelZeroLatticePointDecodesToOneFloatAtEveryLevel) {
    std::mt19937_64 rng(2026);
    std::uniform_real_distribution<double> origin(-1e6, 1e6), exponent(-10, 14), unit(0, 1);
    int checked = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        HlodHeader h;
        h.origin[0] = origin(rng);
        h.root_size = std::exp2(exponent(rng)) * (1 + unit(rng));
        // Anywhere in the model's bounds (the root cell): q0 in [0, 2^15].
        const int64_t q0 = std::min(int64_t(unit(rng) * 32769), int64_t(1) << kLatticeBits);
        const float at_root = decode_coordinate(h, 0, 0, 0, uint16_t(q0 + kLatticeBias));
        for (uint32_t l = 1; l <= 15; ++l) {
            const int64_t q = q0 * (int64_t(1) << l);
            const int64_t cell = std::clamp<int64_t>(q >> kLatticeBits, 0, (int64_t(1) << l) - 1);
            const int64_t stored = q - (cell << kLatticeBits) + kLatticeBias;
            ASSERT_TRUE(stored >= 0 && stored <= 0xFFFF);
            const float at_level = decode_coordinate(h, 0, l, uint32_t(cell), uint16_t(stored));
            ASSERT_EQ(std::memcmp(&at_level, &at_root, 4), 0) << "level " << l << ", q0 " << q0 << ", origin " << h.origin[0]
                                                              << ", root size " << h.root_size;
            ++checked;
        }
    }
    EXPECT_EQ(checked, 3000 * 15);
}

// FNV-1a over a file's bytes.
uint64_t hash_file(const std::filesystem::path& path) {
    uint64_t h = 0xcbf29ce484222325u;
    for (uint8_t b : test::file_bytes(path)) h = (h ^ b) * 0x100000001b3u;
    return h;
}

// The hashes of these builds as the builder wrote them before lock_boundary existed (commit 713de87):
// without the option, not a byte may change. A change that means to alter every model updates them.
TEST(LockBoundary, BuildsWithoutItAreTheBytesTheyWereBeforeIt) {
    test::TempDir dir;
    BuildSettings s;
    s.levels = 2;
    build_hlod(test::colored_grid(120), dir / "grid.hlod", s, "grid");
    build_hlod(test::seamed_grid(96, 36), dir / "seam.hlod", s, "seam");
    s.levels = 3;
    build_hlod(test::icosphere(5), dir / "sphere.hlod", s, "sphere");
    build_hlod(read_mesh(std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "bunny.off"), dir / "bunny.hlod", s, "bunny.off");
    EXPECT_EQ(hash_file(dir / "grid.hlod"), 0x6c4eb026c5ae24aeu);
    EXPECT_EQ(hash_file(dir / "seam.hlod"), 0x927d9cc3cd72c646u);
    EXPECT_EQ(hash_file(dir / "sphere.hlod"), 0xee30ba8aa9b5c7c1u);
    EXPECT_EQ(hash_file(dir / "bunny.hlod"), 0x76f96d3aeec49275u);
}

}  // namespace
}  // namespace strata
