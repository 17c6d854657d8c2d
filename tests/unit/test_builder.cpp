#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/mesh_io.h"
#include "tests/support/test_meshes.h"

#include <gtest/gtest.h>

#include <array>
#include <climits>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

namespace strata {
namespace {

std::vector<char> file_bytes(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

TEST(Builder, ClosedSphereVerifiesAndStaysWatertight) {
    test::TempDir dir;
    Mesh sphere = test::icosphere(6);  // 81 920 triangles
    const size_t input = sphere.triangle_count();
    BuildSettings s;
    s.levels = 3;
    BuildReport report = build_hlod(std::move(sphere), dir / "sphere.hlod", s, "sphere");
    ASSERT_EQ(report.levels.size(), 4u);
    EXPECT_EQ(report.levels.front().triangles, input);
    // Each level keeps about a quarter of the triangles of the finer one (block borders keep a few more).
    for (size_t i = 1; i < report.levels.size(); ++i) {
        double kept = double(report.levels[i].triangles) / double(report.levels[i - 1].triangles);
        EXPECT_GT(kept, 0.2) << "level " << report.levels[i].level;
        EXPECT_LT(kept, 0.45) << "level " << report.levels[i].level;
    }
    HlodFile file(dir / "sphere.hlod");
    VerifyReport v = verify_hlod(file);
    EXPECT_TRUE(v.watertight);
    EXPECT_EQ(file.header().max_level, 3u);
    EXPECT_GT(file.header().error_q, 0.0f);
}

TEST(Builder, OutputIsByteIdenticalAtAnyThreadCount) {
    test::TempDir dir;
    BuildSettings s;
    s.levels = 3;
    s.threads = 1;
    build_hlod(test::icosphere(5), dir / "one.hlod", s, "sphere");
    s.threads = 4;
    build_hlod(test::icosphere(5), dir / "four.hlod", s, "sphere");
    EXPECT_EQ(file_bytes(dir / "one.hlod"), file_bytes(dir / "four.hlod"));
}

TEST(Builder, OpenGridWithColoursAndUvsVerifies) {
    test::TempDir dir;
    BuildSettings s;
    s.levels = 2;
    build_hlod(test::colored_grid(120), dir / "grid.hlod", s, "grid");
    HlodFile file(dir / "grid.hlod");
    EXPECT_TRUE(file.header().has_colors());
    EXPECT_TRUE(file.header().has_uvs());
    VerifyReport v = verify_hlod(file);
    EXPECT_FALSE(v.watertight);
    EXPECT_GT(v.triangles, 2u * 120 * 120);
}

// The seamed grid's seam at x = 3/8 (inside a block at every level, not on a block border, whose
// points are never removed) must survive every level: seam points collapse only along the seam,
// each keeping both copies (left chart u = x, right chart u = x + 1), and every triangle lies on one
// side and uses only its side's copies. A collapse across the seam would give a triangle the other
// side's copy (a smeared texture) or leave a seam point with one copy.
TEST(Builder, UvSeamStaysASeamAndVerifies) {
    test::TempDir dir;
    BuildSettings s;
    s.levels = 2;
    build_hlod(test::seamed_grid(96, 36), dir / "seam.hlod", s, "seam");
    HlodFile file(dir / "seam.hlod");
    const HlodHeader& h = file.header();
    ASSERT_TRUE(h.has_uvs());
    ASSERT_EQ(h.origin[0], 0.0);
    ASSERT_EQ(h.root_size, 1.0);
    verify_hlod(file);

    for (uint32_t level = 0; level <= h.max_level; ++level) {
        // Seam points by their lattice y (the seam's x, 3/8, is exactly on every level's lattice): the
        // charts of the copies that left and right triangles use there.
        const int32_t seam_q = int32_t(3) << (kLatticeBits + level - 3);
        std::map<int32_t, std::array<std::set<int>, 2>> seam_charts;
        size_t triangles = 0;
        for (const HlodNode& n : file.nodes()) {
            if (n.level != level) continue;
            CubeData cube = file.read_cube(n);
            auto lattice_x = [&](uint32_t v) {
                return int32_t(cube.vertices.positions[3 * v]) + int32_t(n.i << kLatticeBits) - kLatticeBias;
            };
            for (size_t t = 0; t < cube.indices.size(); t += 3, ++triangles) {
                int32_t lo = INT32_MAX, hi = INT32_MIN;
                for (int c = 0; c < 3; ++c) lo = std::min(lo, lattice_x(cube.indices[t + c])), hi = std::max(hi, lattice_x(cube.indices[t + c]));
                ASSERT_TRUE(hi <= seam_q || lo >= seam_q) << describe_cube(n) << " triangle " << t / 3 << " crosses the seam";
                const int side = lo >= seam_q;  // 0 left, 1 right
                for (int c = 0; c < 3; ++c) {
                    const uint32_t v = cube.indices[t + c];
                    const float x = decode_coordinate(h, 0, level, n.i, cube.vertices.positions[3 * v]);
                    const float chart = cube.vertices.uvs[2 * v] - x;  // 0 or 1 for a copy of the input
                    EXPECT_NEAR(chart, float(side), 1e-4f) << describe_cube(n) << " triangle " << t / 3
                                                          << " uses the other side's copy at x " << x;
                    if (lattice_x(v) != seam_q) continue;
                    const int32_t y = int32_t(cube.vertices.positions[3 * v + 1]) + int32_t(n.j << kLatticeBits) - kLatticeBias;
                    seam_charts[y][side].insert(int(std::lround(chart)));
                }
            }
        }
        ASSERT_GT(triangles, 0u) << "level " << level;
        // Both ends and some of the line between survive at every level, each point used from both sides.
        EXPECT_GE(seam_charts.size(), 3u) << "level " << level;
        for (const auto& [y, charts] : seam_charts) {
            EXPECT_EQ(charts[0], std::set<int>{0}) << "level " << level << " seam point y " << y << ": its left copy";
            EXPECT_EQ(charts[1], std::set<int>{1}) << "level " << level << " seam point y " << y << ": its right copy";
        }
    }
}

// The bundled real scan (fetched by scripts/setup.sh): bounds from the scan, about a quarter of the
// triangles per level, every invariant, and every level closed like the scan itself.
TEST(Builder, RealScanLevelsBoundsAndClosure) {
    const std::filesystem::path scan = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "bunny.off";
    if (!std::filesystem::exists(scan)) GTEST_SKIP() << scan << " missing: run scripts/setup.sh";
    test::TempDir dir;
    Mesh mesh = read_mesh(scan);
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (size_t v = 0; v < mesh.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], mesh.positions[3 * v + a]), hi[a] = std::max(hi[a], mesh.positions[3 * v + a]);
    const size_t input = mesh.triangle_count();
    BuildReport report = build_hlod(std::move(mesh), dir / "bunny.hlod", BuildSettings{}, "bunny.off");

    HlodFile file(dir / "bunny.hlod");
    const HlodHeader& h = file.header();
    for (int a = 0; a < 3; ++a) EXPECT_EQ(h.origin[a], double(lo[a]));
    EXPECT_EQ(h.root_size, std::max({double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2]}));
    EXPECT_EQ(h.input_triangles, input);
    ASSERT_GE(report.levels.size(), 3u);
    EXPECT_EQ(report.levels.front().triangles, input);
    for (size_t i = 1; i < report.levels.size(); ++i) {
        double kept = double(report.levels[i].triangles) / double(report.levels[i - 1].triangles);
        EXPECT_GT(kept, 0.2) << "level " << report.levels[i].level;
        EXPECT_LT(kept, 0.45) << "level " << report.levels[i].level;
    }
    VerifyReport v = verify_hlod(file);
    EXPECT_TRUE(v.watertight);
}

}  // namespace
}  // namespace strata
