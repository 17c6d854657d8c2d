// Terrains built straight from elevation rasters (issue 17 §1, preprocess/terrain_build.h): the finest
// level is every valid sample where GDAL's own tools put it, nodata leaves holes with open boundaries
// (or is filled), every level is a grid whose cubes stitch (each interior edge used by exactly two
// triangles, once each way), `strata verify`'s invariants hold, and bad rasters fail naming the file
// and leave nothing behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include <geodesic.h>

#include "nodes/hlod_model.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/elevation_raster.h"
#include "preprocess/mesh.h"
#include "preprocess/terrain_build.h"
#include "preprocess/terrain_frame.h"
#include "tests/support/geotiff.h"

#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

namespace strata {
namespace {

namespace fs = std::filesystem;

fs::path data_file(const char* name) { return fs::path(STRATA_SOURCE_DIR) / "data" / name; }

// A rough surface with every sample distinct: hills, a slope and noise.
std::vector<double> rough_heights(int width, int height, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> noise(-3, 3);
    std::vector<double> values;
    for (int r = 0; r < height; ++r)
        for (int c = 0; c < width; ++c)
            values.push_back(std::round(100 + 40 * std::sin(c * 0.21) * std::cos(r * 0.17) + 0.8 * c + noise(rng)));
    return values;
}

// Where a level's vertex lies on the level's lattice (global steps from O): one key per position.
using LatticePoint = std::array<int64_t, 3>;
LatticePoint lattice_point(const HlodModel& model, const HlodCube& cube, uint32_t v) {
    const glm::ivec3 q = model.lattice_steps(cube, v);
    return {q.x, q.y, q.z};
}

struct LevelEdges {
    std::map<std::pair<LatticePoint, LatticePoint>, int> directed;  // every directed edge and how often it appears
    uint64_t triangles = 0;
};

std::vector<LevelEdges> edges_by_level(const HlodModel& model) {
    std::vector<LevelEdges> levels(model.header().max_level + 1);
    for (const HlodCube& cube : model.cubes()) {
        LevelEdges& level = levels[cube.node.level];
        const std::vector<uint32_t>& idx = cube.data->indices;
        for (size_t t = 0; t < idx.size(); t += 3) {
            level.triangles++;
            for (int e = 0; e < 3; ++e)
                level.directed[{lattice_point(model, cube, idx[t + size_t(e)]), lattice_point(model, cube, idx[t + size_t((e + 1) % 3)])}]++;
        }
    }
    return levels;
}

// Every edge appears at most once each way (no fold, no doubled face); returns the edges without a
// twin (the surface's boundary), as the pairs of positions they join.
std::vector<std::pair<LatticePoint, LatticePoint>> boundary(const LevelEdges& level, uint32_t l) {
    std::vector<std::pair<LatticePoint, LatticePoint>> open;
    for (const auto& [edge, count] : level.directed) {
        EXPECT_EQ(count, 1) << "level " << l << ": a directed edge used " << count << " times";
        if (!level.directed.count({edge.second, edge.first})) open.push_back(edge);
    }
    return open;
}

BuildReport build(const fs::path& dem, const fs::path& out, TerrainSettings settings = {}) {
    BuildReport report = build_terrain({dem}, out, settings, dem.filename().string());
    EXPECT_NO_THROW(verify_hlod(HlodFile(out)));
    return report;
}

// Level L's vertices in CRS coordinates, by the sample (column, row) they stand at, with their cube's
// error bound; `g` the raster's geotransform.
struct FinestVertex {
    std::array<double, 3> geo;
    float cube_error;
};
std::map<std::pair<int64_t, int64_t>, FinestVertex> finest_vertices(const HlodModel& model, const std::array<double, 6>& g) {
    const HlodHeader& h = model.header();
    std::map<std::pair<int64_t, int64_t>, FinestVertex> finest;
    for (const HlodCube& cube : model.cubes()) {
        if (cube.node.level != h.max_level) continue;
        for (uint32_t v = 0; v < cube.data->vertex_count(); ++v) {
            const glm::vec3 p = model.vertex_position(cube, v);
            const std::array<double, 3> geo{h.geo_origin[0] + h.origin[0] + p.x, h.geo_origin[1] + h.origin[1] + p.y,
                                            h.geo_origin[2] + h.origin[2] + p.z};
            const int64_t column = std::llround((geo[0] - g[0]) / g[1] - 0.5), row = std::llround((geo[1] - g[3]) / g[5] - 0.5);
            finest[{column, row}] = {geo, cube.node.error};
        }
    }
    return finest;
}

std::array<double, 6> geotransform(const nlohmann::json& info) {
    std::array<double, 6> g;
    for (size_t i = 0; i < 6; ++i) g[i] = info["geoTransform"][i];
    return g;
}

TEST(TerrainBuild, TheFinestLevelIsEverySampleWhereGdalPutsIt) {
    const fs::path dem = data_file("olinda_dem.tif");
    if (!fs::exists(dem)) GTEST_SKIP() << "data/olinda_dem.tif missing: run scripts/setup.sh";
    test::TempDir dir;
    build(dem, dir / "olinda.hlod", {.height_tolerance = 0.0});
    const auto model = HlodModel::load(dir / "olinda.hlod");
    const HlodHeader& h = model->header();
    EXPECT_FALSE(h.crs.empty());

    const nlohmann::json info = test::gdalinfo(dem);
    const std::array<double, 6> g = geotransform(info);
    const int width = info["size"][0], height = info["size"][1];
    const auto finest = finest_vertices(*model, g);
    EXPECT_EQ(finest.size(), size_t(width) * size_t(height)) << "every sample of the DEM (it has no nodata) is a vertex";

    std::mt19937 rng(17);
    std::vector<std::pair<uint64_t, uint64_t>> pixels;
    for (int s = 0; s < 300; ++s) pixels.push_back({rng() % uint64_t(width), rng() % uint64_t(height)});
    const std::vector<double> values = test::gdal_values(dem, pixels);
    ASSERT_EQ(values.size(), pixels.size());
    const double step = h.lattice_step(h.max_level);
    for (size_t s = 0; s < pixels.size(); ++s) {
        const auto [column, row] = pixels[s];
        auto it = finest.find({int64_t(column), int64_t(row)});
        ASSERT_NE(it, finest.end()) << "no vertex at column " << column << ", row " << row;
        EXPECT_NEAR(it->second.geo[0], g[0] + (column + 0.5) * g[1], step) << column << ", " << row;
        EXPECT_NEAR(it->second.geo[1], g[3] + (row + 0.5) * g[5], step) << column << ", " << row;
        EXPECT_NEAR(it->second.geo[2], values[s], step) << column << ", " << row;
    }
}

// Heights lie on a coarser lattice than positions (FORMAT.md §5.1), within the tolerance asked for
// (default 1/128 of the spacing): every sample's vertex is within it of GDAL's value and within its
// cube's error bound, the file is smaller for it, and a larger tolerance moves heights further.
TEST(TerrainBuild, HeightsStayWithinTheirToleranceAndTheirCubesBound) {
    const fs::path dem = data_file("olinda_dem.tif");
    if (!fs::exists(dem)) GTEST_SKIP() << "data/olinda_dem.tif missing: run scripts/setup.sh";
    test::TempDir dir;
    const nlohmann::json info = test::gdalinfo(dem);
    const std::array<double, 6> g = geotransform(info);
    const int width = info["size"][0], height = info["size"][1];
    std::vector<std::pair<uint64_t, uint64_t>> pixels;
    for (uint64_t r = 0; r < uint64_t(height); r += 3)
        for (uint64_t c = 0; c < uint64_t(width); c += 3) pixels.push_back({c, r});
    const std::vector<double> values = test::gdal_values(dem, pixels);
    ASSERT_EQ(values.size(), pixels.size());

    build(dem, dir / "exact.hlod", {.height_tolerance = 0.0});
    const uintmax_t exact_bytes = fs::file_size(dir / "exact.hlod");
    std::vector<double> worst;
    for (const std::optional<double> tolerance : {std::optional<double>(), std::optional<double>(3.0)}) {
        build(dem, dir / "olinda.hlod", {.height_tolerance = tolerance});
        EXPECT_LT(fs::file_size(dir / "olinda.hlod"), exact_bytes);
        const auto model = HlodModel::load(dir / "olinda.hlod");
        const double allowed = tolerance.value_or(std::abs(g[1]) / 128) + model->header().lattice_step(model->header().max_level) / 2;
        const auto finest = finest_vertices(*model, g);
        double moved = 0;
        for (size_t s = 0; s < pixels.size(); ++s) {
            auto it = finest.find({int64_t(pixels[s].first), int64_t(pixels[s].second)});
            ASSERT_NE(it, finest.end());
            const double off = std::abs(it->second.geo[2] - values[s]);
            EXPECT_LE(off, allowed) << pixels[s].first << ", " << pixels[s].second;
            EXPECT_LE(off, it->second.cube_error * (1 + 1e-6)) << pixels[s].first << ", " << pixels[s].second;
            moved = std::max(moved, off);
        }
        worst.push_back(moved);
    }
    EXPECT_GT(worst[1], 2 * worst[0]) << "a larger tolerance moves heights further";
}

// 75 × 53 samples (so both the last column and the last row of some levels are narrower), cubes of 16
// cells, a block of nodata, scattered nodata pixels and a small island inside a nodata moat.
test::TiffSpec holes_spec(std::vector<bool>& valid) {
    test::TiffSpec spec{.width = 75, .height = 53, .type = GDT_Float32, .nodata = -9999};
    spec.values = rough_heights(spec.width, spec.height, 5);
    valid.assign(spec.values.size(), true);
    auto hole = [&](int c, int r) {
        spec.values[size_t(r * spec.width + c)] = -9999;
        valid[size_t(r * spec.width + c)] = false;
    };
    for (int r = 10; r < 22; ++r)
        for (int c = 30; c < 47; ++c) hole(c, r);
    for (int s = 0; s < 40; ++s) hole((s * 37) % 75, (s * 11 + 3) % 53);
    for (int r = 35; r < 46; ++r)
        for (int c = 5; c < 16; ++c)
            if (r < 39 || r > 41 || c < 9 || c > 11) hole(c, r);  // a moat around a 3 × 3 island
    return spec;
}

TEST(TerrainBuild, NodataLeavesHolesWithOpenBoundariesAndEveryLevelStitches) {
    test::TempDir dir;
    std::vector<bool> valid;
    const test::TiffSpec spec = holes_spec(valid);
    test::write_tiff(dir / "holes.tif", spec);
    const BuildReport report = build(dir / "holes.tif", dir / "holes.hlod", {.cube_cells = 16});
    const auto model = HlodModel::load(dir / "holes.hlod");
    const HlodHeader& h = model->header();
    ASSERT_GE(h.max_level, 2u);

    // Level L: a triangle wherever the cell's diagonal corners and a third are all valid.
    auto ok = [&](int c, int r) { return valid[size_t(r * spec.width + c)]; };
    uint64_t expected = 0;
    for (int r = 0; r + 1 < spec.height; ++r)
        for (int c = 0; c + 1 < spec.width; ++c)
            if (ok(c, r) && ok(c + 1, r + 1)) expected += ok(c, r + 1) + ok(c + 1, r);
    EXPECT_EQ(report.input_triangles, expected);

    const std::vector<LevelEdges> levels = edges_by_level(*model);
    EXPECT_EQ(levels[h.max_level].triangles, expected);
    // Level L's boundary runs along the raster's border and nodata only: an open edge joins two
    // samples at least one of whose cells (the two beside the edge) lacks a valid corner.
    const double spacing = spec.geotransform[1], lattice = h.lattice_step(h.max_level);
    auto sample = [&](const LatticePoint& q) {
        const int c = int(std::lround((h.origin[0] + double(q[0]) * lattice) / spacing));
        const int r = spec.height - 1 - int(std::lround((h.origin[1] + double(q[1]) * lattice) / spacing));
        return std::pair{c, r};
    };
    for (const auto& [a, b] : boundary(levels[h.max_level], h.max_level)) {
        const auto [ca, ra] = sample(a);
        const auto [cb, rb] = sample(b);
        bool beside_a_hole = false;
        for (int dr = -1; dr <= 1; ++dr)
            for (int dc = -1; dc <= 1; ++dc)
                for (const auto& [c, r] : {std::pair{ca + dc, ra + dr}, std::pair{cb + dc, rb + dr}})
                    beside_a_hole = beside_a_hole || c < 0 || r < 0 || c >= spec.width || r >= spec.height || !ok(c, r);
        EXPECT_TRUE(beside_a_hole) << "an open edge from sample " << ca << "," << ra << " to " << cb << "," << rb
                                   << " inside valid ground: a crack";
    }
    for (uint32_t l = 0; l < h.max_level; ++l) {
        boundary(levels[l], l);
        EXPECT_GT(levels[l].triangles, 0u) << "level " << l;
    }
}

// The sample count along an axis at each level, coarse to fine: every other sample and the last,
// ⌊n/2⌋ + 1 of n whether n is odd or even.
std::vector<uint64_t> axis_counts(uint64_t samples, uint32_t levels) {
    std::vector<uint64_t> counts{samples};
    while (counts.size() < levels) counts.insert(counts.begin(), counts.front() / 2 + 1);
    return counts;
}

TEST(TerrainBuild, FilledNodataMakesEveryLevelOneWholeGrid) {
    test::TempDir dir;
    std::vector<bool> valid;
    test::write_tiff(dir / "holes.tif", holes_spec(valid));
    build(dir / "holes.tif", dir / "filled.hlod", {.cube_cells = 16, .fill = 130.0f, .height_tolerance = 0.0});
    const auto model = HlodModel::load(dir / "filled.hlod");
    const HlodHeader& h = model->header();
    // A sample of the nodata block (column 35, row 15) is ground at the fill's height.
    bool filled = false;
    for (const HlodCube& cube : model->cubes())
        for (uint32_t v = 0; cube.node.level == h.max_level && v < cube.data->vertex_count(); ++v) {
            const glm::vec3 p = model->vertex_position(cube, v);
            if (std::abs(h.origin[0] + p.x - 35 * 30.0) < 1 && std::abs(h.origin[1] + p.y - (52 - 15) * 30.0) < 1)
                filled = std::abs(h.origin[2] + p.z - 130) <= h.lattice_step(h.max_level);
        }
    EXPECT_TRUE(filled);
    const std::vector<LevelEdges> levels = edges_by_level(*model);
    const std::vector<uint64_t> columns = axis_counts(75, h.max_level + 1), rows = axis_counts(53, h.max_level + 1);
    for (uint32_t l = 0; l <= h.max_level; ++l) {
        const uint64_t w = columns[l], r = rows[l];
        EXPECT_EQ(levels[l].triangles, 2 * (w - 1) * (r - 1)) << "level " << l;
        EXPECT_EQ(boundary(levels[l], l).size(), 2 * (w - 1) + 2 * (r - 1)) << "level " << l << ": open inside";
    }
}

// Out of core (issue 17): a raster cut into tiles, each read with a margin, builds into the same bytes
// as the raster read whole, however the tiles fall (a last tile cut short, tiles of one cube).
TEST(TerrainBuild, TiledBuildsAreByteIdenticalToTheWholeRastersBuild) {
    test::TempDir dir;
    std::vector<bool> valid;
    test::write_tiff(dir / "holes.tif", holes_spec(valid));
    struct Case {
        fs::path dem;
        uint32_t cube_cells;
        std::vector<std::array<uint32_t, 2>> tiles;
    };
    std::vector<Case> cases{{dir / "holes.tif", 16, {{1, 1}, {2, 1}, {2, 3}, {3, 1}, {3, 3}}}};
    if (fs::exists(data_file("olinda_dem.tif"))) cases.push_back({data_file("olinda_dem.tif"), 8, {{2, 1}, {3, 2}, {4, 5}}});
    for (const Case& c : cases) {
        build(c.dem, dir / "whole.hlod", {.cube_cells = c.cube_cells});
        const std::vector<uint8_t> whole = test::file_bytes(dir / "whole.hlod");
        for (const auto& tiles : c.tiles) {
            build(c.dem, dir / "tiled.hlod", {.cube_cells = c.cube_cells, .tiles = tiles});
            EXPECT_TRUE(test::file_bytes(dir / "tiled.hlod") == whole)
                << c.dem.filename() << " in tiles of " << tiles[1] << " level-" << tiles[0] << " cubes differs from the whole raster's build";
        }
    }
}

// A DEM in degrees (EPSG:4326, 0.6° × 0.5° of the Alps at 0.005°): in the enu frame each sample lies
// where PROJ puts its ellipsoid point in the tangent plane at the centre, at its height; in ecef where
// PROJ puts the point itself. Horizontal distances differ from the ellipsoid's geodesics (PROJ's
// geod_inverse) by at most the documented (d/R)²/2 of the tangent plane.
TEST(TerrainBuild, ADemInDegreesLiesInATangentPlaneAtItsCentre) {
    test::TempDir dir;
    test::TiffSpec spec{.width = 121, .height = 101, .type = GDT_Float32, .geotransform = {7.0, 0.005, 0, 47.0, 0, -0.005}, .crs = "EPSG:4326"};
    spec.values = rough_heights(spec.width, spec.height, 8);
    test::write_tiff(dir / "alps.tif", spec);
    const double lon0 = 7.0 + 0.005 * (60 + 0.5), lat0 = 47.0 - 0.005 * (50 + 0.5);  // the centre sample
    const test::Topocentric topocentric(lon0, lat0);
    ASSERT_TRUE(topocentric.ok());
    geod_geodesic wgs84;
    geod_init(&wgs84, 6378137, 1 / 298.257223563);

    for (const TerrainFrameKind frame : {TerrainFrameKind::enu, TerrainFrameKind::ecef}) {
        SCOPED_TRACE(frame == TerrainFrameKind::enu ? "enu" : "ecef");
        build(dir / "alps.tif", dir / "alps.hlod", {.cube_cells = 16, .frame = frame, .height_tolerance = 0.0});
        const auto model = HlodModel::load(dir / "alps.hlod");
        const HlodHeader& h = model->header();
        ASSERT_TRUE(h.terrain);
        EXPECT_EQ(h.terrain->frame, uint32_t(frame));
        EXPECT_NEAR(h.geo_origin[0], lon0, 1e-9);
        EXPECT_NEAR(h.geo_origin[1], lat0, 1e-9);
        std::vector<std::array<double, 3>> finest;
        for (const HlodCube& cube : model->cubes())
            for (uint32_t v = 0; cube.node.level == h.max_level && v < cube.data->vertex_count(); ++v) {
                const glm::vec3 p = model->vertex_position(cube, v);
                finest.push_back({h.origin[0] + p.x, h.origin[1] + p.y, h.origin[2] + p.z});
            }
        auto vertex_near = [&](const std::array<double, 3>& want) {
            double best = INFINITY;
            std::array<double, 3> found{};
            for (const auto& p : finest)
                if (const double d = std::hypot(p[0] - want[0], p[1] - want[1]); d < best) best = d, found = p;
            return found;
        };
        std::mt19937 rng(3);
        const double step = h.lattice_step(h.max_level);
        double worst_distortion = 0;
        for (int s = 0; s < 60; ++s) {
            const int c = int(rng() % 121), r = int(rng() % 101), c2 = int(rng() % 121), r2 = int(rng() % 101);
            const double lon = 7.0 + 0.005 * (c + 0.5), lat = 47.0 - 0.005 * (r + 0.5), height = spec.values[size_t(r * 121 + c)];
            const std::array<double, 3> at_zero = topocentric(lon, lat, 0), at_height = topocentric(lon, lat, height);
            const std::array<double, 3> want = frame == TerrainFrameKind::enu ? std::array{at_zero[0], at_zero[1], height} : at_height;
            const std::array<double, 3> got = vertex_near(want);
            for (int a = 0; a < 3; ++a) EXPECT_NEAR(got[size_t(a)], want[size_t(a)], step) << "sample " << c << ", " << r << " axis " << a;
            if (frame != TerrainFrameKind::enu) continue;
            // The frame's horizontal distance against the geodesic between the two samples.
            const TerrainFrame plane = TerrainFrame::for_raster(ElevationRaster::open({dir / "alps.tif"}).info());
            const std::array<double, 3> a = plane.position(uint64_t(c), uint64_t(r), 0), b = plane.position(uint64_t(c2), uint64_t(r2), 0);
            double geodesic = 0;
            geod_inverse(&wgs84, lat, lon, 47.0 - 0.005 * (r2 + 0.5), 7.0 + 0.005 * (c2 + 0.5), &geodesic, nullptr, nullptr);
            if (geodesic > 1000) worst_distortion = std::max(worst_distortion, std::abs(std::hypot(b[0] - a[0], b[1] - a[1]) - geodesic) / geodesic);
        }
        if (frame == TerrainFrameKind::enu) {
            const double reach = 40e3 / 6371e3;  // the farthest sample from the centre, over the Earth's radius
            EXPECT_LT(worst_distortion, reach * reach / 2);
            std::printf("enu: distances in the plane within %.2g of the geodesics (bound (d/R)²/2 = %.2g)\n", worst_distortion, reach * reach / 2);
        }
    }
}

std::string build_error(const fs::path& dem, const fs::path& out) {
    try {
        build_terrain({dem}, out, {}, dem.filename().string());
    } catch (const InputError& e) {
        return e.what();
    }
    return "(built)";
}

TEST(TerrainBuild, BadRastersFailNamingTheFileAndLeaveNothing) {
    test::TempDir dir;
    const std::vector<double> heights = rough_heights(20, 16, 3);
    struct Case {
        const char* name;
        test::TiffSpec spec;
        const char* says;
    };
    const Case cases[] = {
        {"feet.tif", {.width = 20, .height = 16, .values = heights, .crs = "EPSG:2227"}, "units of 0.3048"},
        {"bands.tif", {.width = 20, .height = 16, .bands = 3, .values = heights}, "band"},
        {"nowhere.tif", {.width = 20, .height = 16, .values = heights, .georeferenced = false, .crs = ""}, "geotransform"},
        {"empty.tif", {.width = 20, .height = 16, .values = std::vector<double>(320, -1), .nodata = -1}, "nodata everywhere"},
    };
    for (const Case& c : cases) {
        test::write_tiff(dir / c.name, c.spec);
        const std::string error = build_error(dir / c.name, dir / "out.hlod");
        EXPECT_NE(error.find(c.name), std::string::npos) << c.name << ": " << error;
        EXPECT_NE(error.find(c.says), std::string::npos) << c.name << ": " << error;
    }
    // A GeoTIFF cut short: its samples cannot be read.
    test::write_tiff(dir / "whole.tif", {.width = 300, .height = 200, .values = rough_heights(300, 200, 4)});
    const std::vector<uint8_t> bytes = test::file_bytes(dir / "whole.tif");
    std::ofstream(dir / "truncated.tif", std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size() / 2));
    EXPECT_NE(build_error(dir / "truncated.tif", dir / "out.hlod").find("truncated.tif"), std::string::npos);

    std::set<std::string> left;
    for (const auto& entry : fs::directory_iterator(dir.path())) left.insert(entry.path().filename().string());
    EXPECT_EQ(left.count("out.hlod"), 0u);
    for (const std::string& name : left) EXPECT_EQ(name.find("out.hlod"), std::string::npos) << name << " left behind";
}

}  // namespace
}  // namespace strata
