#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/mesh_io.h"
#include "tests/support/test_meshes.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

namespace strata {
namespace {

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
    EXPECT_EQ(test::file_bytes(dir / "one.hlod"), test::file_bytes(dir / "four.hlod"));
}

// A vertex no triangle of its cube uses (an "extra", FORMAT.md §9) is there only to be a child's
// parent; it must not be carried up level after level. Four levels of blocks under one (16 cubes a side
// at level 4): coarse cubes hold the vertices their triangles use and next to nothing else.
TEST(Builder, CoarseCubesDoNotCarryTheExtraVerticesOfFinerLevels) {
    test::TempDir dir;
    BuildSettings s;
    s.levels = 4;
    build_hlod(test::icosphere(7), dir / "sphere.hlod", s, "sphere");  // 327 680 triangles
    HlodFile file(dir / "sphere.hlod");
    ASSERT_TRUE(verify_hlod(file).watertight);
    std::vector<uint64_t> vertices(5), extras(5);
    for (const HlodNode& n : file.nodes()) {
        const CubeData cube = decode_cube(file.read_payload(n), n, file.header().flags);
        std::vector<bool> used(cube.vertex_count());
        for (uint32_t i : cube.indices) used[i] = true;
        vertices[n.level] += cube.vertex_count();
        extras[n.level] += uint64_t(std::count(used.begin(), used.end(), false));
    }
    EXPECT_EQ(extras[4], 0u) << "level L holds the input's own vertices";
    for (uint32_t level = 0; level < 4; ++level)
        EXPECT_LE(extras[level], vertices[level] / 50) << "level " << level << ": " << extras[level] << " extras of "
                                                       << vertices[level] << " vertices";
}

std::vector<std::string> names_in(const std::filesystem::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

TEST(Builder, LevelsPassThroughTheTemporaryFolderWhichIsRemovedAfter) {
    test::TempDir dir;
    std::filesystem::create_directory(dir / "scratch");
    BuildSettings s;
    s.levels = 3;
    s.temp_dir = dir / "scratch";
    // Once a job of stage 2 (level 2 simplified) has finished, the work folder holds the plan, stage 1's
    // payloads and the level-2 cubes its jobs made, and stage 2's first files; the spill and stage 0's
    // level-3 cubes, which only stage 1 read, are gone.
    std::vector<std::string> seen;
    Progress progress;
    progress.report = [&](std::string_view stage, double, double, std::string_view) {
        if (stage != "simplify level 2" || !seen.empty()) return;
        for (const auto& e : std::filesystem::recursive_directory_iterator(dir / "scratch")) {
            const std::string name = std::filesystem::relative(e.path(), dir / "scratch").string();
            if (name.find(".tmp-") != std::string::npos) continue;  // a file the other worker is writing
            const size_t dot = name.rfind('.');
            // a job's file by its stage and kind: "stage-1/….cubes" as "stage-1/*.cubes"
            seen.push_back(name.find('/', 16) != std::string::npos && dot != std::string::npos
                               ? name.substr(0, name.rfind('/') + 1) + "*" + name.substr(dot)
                               : name);
        }
        std::sort(seen.begin(), seen.end());
        seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    };
    const BuildReport report = build_hlod(test::icosphere(5), dir / "out.hlod", s, "sphere", progress);
    EXPECT_EQ(seen, (std::vector<std::string>{"out.hlod.build", "out.hlod.build/jobs.txt", "out.hlod.build/lock",
                                              "out.hlod.build/plan", "out.hlod.build/stage-0.done",
                                              "out.hlod.build/stage-1", "out.hlod.build/stage-1.done",
                                              "out.hlod.build/stage-1/*.cubes", "out.hlod.build/stage-1/*.payloads",
                                              "out.hlod.build/stage-2", "out.hlod.build/stage-2/*.cubes",
                                              "out.hlod.build/stage-2/*.payloads"}));
    EXPECT_TRUE(names_in(dir / "scratch").empty());
    EXPECT_EQ(names_in(dir.path()), (std::vector<std::string>{"out.hlod", "scratch"}));
    // The largest two consecutive levels' cubes, raw: more than the model's compressed bytes.
    EXPECT_GT(report.temp_bytes, report.output_bytes);

    // Where the temporary files go changes nothing in the output.
    s.temp_dir.clear();
    build_hlod(test::icosphere(5), dir / "beside.hlod", s, "sphere");
    EXPECT_EQ(test::file_bytes(dir / "out.hlod"), test::file_bytes(dir / "beside.hlod"));
}

TEST(Builder, TemporaryFolderThatCannotBeMadeIsNamedAndLeavesNothing) {
    test::TempDir dir;
    std::ofstream(dir / "plain-file") << "not a folder";
    BuildSettings s;
    s.levels = 2;
    s.temp_dir = dir / "plain-file" / "scratch";
    try {
        build_hlod(test::icosphere(3), dir / "out.hlod", s, "sphere");
        ADD_FAILURE() << "built with its temporary folder under a plain file";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find((dir / "plain-file").string()), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("cannot create the build's work folder"), std::string::npos) << e.what();
    }
    EXPECT_EQ(names_in(dir.path()), (std::vector<std::string>{"plain-file"}));
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


// The scan cut into tiles by triangle barycenter (x), each tile holding only its own triangles and the
// vertices they use, so the tiles repeat the vertices along their borders.
std::vector<Mesh> cut_into_tiles(const Mesh& mesh, const std::vector<float>& cuts) {
    std::vector<Mesh> tiles(cuts.size() + 1);
    std::vector<std::vector<uint32_t>> new_index(tiles.size(), std::vector<uint32_t>(mesh.vertex_count(), UINT32_MAX));
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        float x = 0;
        for (int c = 0; c < 3; ++c) x += mesh.positions[3 * mesh.indices[t + c]] / 3;
        const size_t tile = size_t(std::upper_bound(cuts.begin(), cuts.end(), x) - cuts.begin());
        Mesh& out = tiles[tile];
        for (int c = 0; c < 3; ++c) {
            uint32_t& index = new_index[tile][mesh.indices[t + c]];
            if (index == UINT32_MAX) {
                index = uint32_t(out.vertex_count());
                const float* p = &mesh.positions[3 * mesh.indices[t + c]];
                out.positions.insert(out.positions.end(), p, p + 3);
            }
            out.indices.push_back(index);
        }
    }
    return tiles;
}

std::vector<uint64_t> triangles_per_level(const std::filesystem::path& model) {
    HlodFile file(model);
    std::vector<uint64_t> counts(file.header().max_level + 1);
    for (const HlodNode& n : file.nodes()) counts[n.level] += n.triangle_count;
    return counts;
}

// Tiles that share their border vertices weld into one closed surface: the build from three tiles is
// watertight at every level, holds every triangle of the scan, and is byte for byte the build of the
// one file that lists the same triangles in the same order.
TEST(Builder, TilesOfAClosedScanWeldIntoTheWholeModel) {
    const std::filesystem::path scan = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "bunny.off";
    if (!std::filesystem::exists(scan)) GTEST_SKIP() << scan << " missing: run scripts/setup.sh";
    test::TempDir dir;
    const Mesh whole = read_mesh(scan);
    float lo = 1e30f, hi = -1e30f;
    for (size_t v = 0; v < whole.vertex_count(); ++v) lo = std::min(lo, whole.positions[3 * v]), hi = std::max(hi, whole.positions[3 * v]);
    const std::vector<Mesh> tiles = cut_into_tiles(whole, {lo + 0.3f * (hi - lo), lo + 0.6f * (hi - lo)});
    std::vector<std::filesystem::path> paths;
    Mesh in_tile_order;  // the tiles end to end, as one file would list them
    for (size_t i = 0; i < tiles.size(); ++i) {
        ASSERT_GT(tiles[i].triangle_count(), 1000u) << "tile " << i;
        paths.push_back(dir / ("tile" + std::to_string(i) + ".ply"));
        write_ply(paths.back(), tiles[i]);
        const uint32_t base = uint32_t(in_tile_order.vertex_count());
        in_tile_order.positions.insert(in_tile_order.positions.end(), tiles[i].positions.begin(), tiles[i].positions.end());
        for (uint32_t index : tiles[i].indices) in_tile_order.indices.push_back(base + index);
    }
    write_ply(dir / "whole.ply", in_tile_order);

    std::vector<std::string> warnings;
    Mesh merged = read_tiles(paths, {}, warnings);
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(merged.vertex_count(), whole.vertex_count()) << "border vertices were not welded";
    EXPECT_EQ(merged.triangle_count(), whole.triangle_count());
    build_hlod(std::move(merged), dir / "tiles.hlod", BuildSettings{}, "3 files");
    build_hlod(read_mesh(dir / "whole.ply"), dir / "whole.hlod", BuildSettings{}, "3 files");

    HlodFile file(dir / "tiles.hlod");
    EXPECT_EQ(file.header().input_triangles, whole.triangle_count());
    const VerifyReport v = verify_hlod(file);
    EXPECT_TRUE(v.watertight) << "the tiles' borders left holes";
    EXPECT_EQ(test::file_bytes(dir / "tiles.hlod"), test::file_bytes(dir / "whole.hlod"));
    // The scan's own order gives the same model up to the order of its vertices: the same counts.
    build_hlod(read_mesh(scan), dir / "scan.hlod", BuildSettings{}, "bunny.off");
    EXPECT_EQ(triangles_per_level(dir / "tiles.hlod"), triangles_per_level(dir / "scan.hlod"));
}

// A survey scan in UTM coordinates (eastings of 6 digits, northings of 7, in metres) with millimetre
// detail: the model's decoded finest level lies within a millimetre of the input, where float input
// positions would be off by up to a quarter metre.
TEST(Builder, SurveyCoordinatesKeepTheirMillimetres) {
    test::TempDir dir;
    constexpr int kSide = 24;
    std::vector<std::array<double, 3>> points;
    for (int j = 0; j <= kSide; ++j)
        for (int i = 0; i <= kSide; ++i)
            points.push_back({512345.678 + 0.25 * i + 0.001 * ((i * 7 + j) % 5),
                              5412345.123 + 0.25 * j + 0.001 * ((i + 3 * j) % 4), 300.0 + 0.001 * ((i * j) % 7)});
    std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(points.size()) +
                      "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
                      std::to_string(2 * kSide * kSide) + "\nproperty list uchar uint vertex_indices\nend_header\n";
    for (const auto& p : points) ply.append(reinterpret_cast<const char*>(p.data()), 24);
    auto face = [&](uint32_t a, uint32_t b, uint32_t c) {
        ply.push_back(3);
        for (uint32_t v : {a, b, c}) ply.append(reinterpret_cast<const char*>(&v), 4);
    };
    for (uint32_t j = 0; j < kSide; ++j)
        for (uint32_t i = 0; i < kSide; ++i) {
            const uint32_t a = j * (kSide + 1) + i;
            face(a, a + 1, a + kSide + 2);
            face(a, a + kSide + 2, a + kSide + 1);
        }
    std::ofstream(dir / "survey.ply", std::ios::binary) << ply;

    BuildSettings s;
    s.levels = 2;
    build_hlod(read_mesh(dir / "survey.ply"), dir / "survey.hlod", s, "survey.ply");
    HlodFile file(dir / "survey.hlod");
    const HlodHeader& h = file.header();
    HlodHeader at_zero = h;  // decode_coordinate adds the origin in float; the true one is added in double
    for (double& o : at_zero.origin) o = 0;
    size_t checked = 0;
    for (const HlodNode& n : file.nodes()) {
        if (n.level != h.max_level) continue;
        const CubeData cube = file.read_cube(n);
        const uint32_t cell[3] = {n.i, n.j, n.k};
        for (uint32_t v = 0; v < n.vertex_count; ++v, ++checked) {
            std::array<double, 3> x;
            for (int a = 0; a < 3; ++a)
                x[a] = h.origin[a] + double(decode_coordinate(at_zero, a, n.level, cell[a], cube.vertices.positions[3 * v + a]));
            double nearest = INFINITY;
            for (const auto& p : points)
                nearest = std::min(nearest, std::max({std::abs(p[0] - x[0]), std::abs(p[1] - x[1]), std::abs(p[2] - x[2])}));
            EXPECT_LT(nearest, 0.001) << describe_cube(n) << " vertex " << v << " at " << x[0] << " " << x[1] << " " << x[2];
        }
    }
    EXPECT_GE(checked, points.size());  // vertices on cube borders are in every cube they touch
}

}  // namespace
}  // namespace strata
