#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/mesh_io.h"
#include "tests/support/test_meshes.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

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

TEST(Builder, UvSeamStaysASeamAndVerifies) {
    test::TempDir dir;
    BuildSettings s;
    s.levels = 2;
    build_hlod(test::seamed_grid(96), dir / "seam.hlod", s, "seam");
    HlodFile file(dir / "seam.hlod");
    ASSERT_TRUE(file.header().has_uvs());
    verify_hlod(file);
    // No triangle may mix the two charts (u < 0.5 + ε on the left, u ≥ 0.5 on the right copy): a
    // collapse across the seam would smear the texture.
    for (const HlodNode& n : file.nodes()) {
        CubeData cube = file.read_cube(n);
        for (size_t t = 0; t < cube.indices.size(); t += 3) {
            int charts[2] = {0, 0};
            for (int c = 0; c < 3; ++c) {
                float u = cube.vertices.uvs[2 * size_t(cube.indices[t + c])];
                if (u < 0.499f) charts[0]++;
                if (u > 1.001f) charts[1]++;
            }
            EXPECT_FALSE(charts[0] && charts[1]) << describe_cube(n) << " triangle " << t / 3;
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
