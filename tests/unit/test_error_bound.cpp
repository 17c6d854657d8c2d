// The cubes' error bound (preprocess/error_bound.h, FORMAT.md §13) against the full-resolution scan,
// sampled densely and measured exactly: no cube of the real bunny or of a real terrain is farther from the scan than its
// stored error (its triangles, as decoded, to the scan), nor the scan under it from its level (the
// scan's triangles to the level's surface). Prints how tight the bound is: sampled / bound.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include "nodes/hlod_model.h"
#include "preprocess/mesh_io.h"
#include "preprocess/surface_distance.h"
#include "preprocess/terrain_build.h"
#include "tests/support/bunny_model.h"
#include "tests/support/dem_grid.h"
#include "tests/support/geotiff.h"

#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

namespace strata {
namespace {

struct Surface {
    std::vector<float> positions;
    std::vector<uint32_t> triangles;
    SurfaceView view() const { return {positions, triangles}; }
};

// Points on a triangle: its corners, its centroid and a few random ones.
template <class Visit>
void sample_triangle(const float* a, const float* b, const float* c, std::mt19937& rng, Visit&& visit) {
    std::uniform_real_distribution<double> unit(0, 1);
    const double fixed[4][2] = {{0, 0}, {1, 0}, {0, 1}, {1.0 / 3, 1.0 / 3}};
    for (int s = 0; s < 6; ++s) {
        double r1, r2;
        if (s < 4) {
            r1 = fixed[s][0], r2 = fixed[s][1];
        } else {
            r1 = unit(rng), r2 = unit(rng);
            if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
        }
        double p[3];
        for (int k = 0; k < 3; ++k) p[k] = a[k] * (1 - r1 - r2) + b[k] * r1 + c[k] * r2;
        visit(p);
    }
}

struct Tightness {
    std::vector<double> ratios;  // sampled / bound, per cube
    void add(double sampled, double bound) { ratios.push_back(sampled / bound); }
    double median() {
        std::sort(ratios.begin(), ratios.end());
        return ratios.empty() ? 0 : ratios[ratios.size() / 2];
    }
    double max() const { return ratios.empty() ? 0 : *std::max_element(ratios.begin(), ratios.end()); }
};

// Every cube of `model` against `scan`, the mesh it was built from.
void expect_bounded(const HlodModel& hlod, const Mesh& scan) {
    const HlodModel* model = &hlod;
    const HlodHeader& h = model->header();
    ASSERT_TRUE(h.flags & kErrorsAreBounds);

    // The scan in the lattice frame (model units, origin at O), where the model's cubes decode.
    Surface full;
    for (size_t v = 0; v < scan.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a)
            full.positions.push_back(float(scan.origin[size_t(a)] + scan.positions[3 * v + size_t(a)] - h.origin[a]));
    full.triangles = scan.indices;
    const TriangleTree full_tree(full.view(), {});

    std::mt19937 rng(15);
    for (uint32_t level = 0; level <= h.max_level; ++level) {
        // The level's surface as decoded, each triangle knowing its cube.
        Surface drawn;
        std::vector<uint32_t> cube_of;
        std::map<std::array<uint32_t, 3>, uint32_t> by_cell;
        for (uint32_t c = 0; c < model->cubes().size(); ++c) {
            const HlodCube& cube = model->cubes()[c];
            if (cube.node.level != level) continue;
            by_cell[{cube.node.i, cube.node.j, cube.node.k}] = c;
            const uint32_t first = uint32_t(drawn.positions.size() / 3);
            for (uint32_t v = 0; v < cube.data->vertex_count(); ++v) {
                const glm::vec3 p = model->vertex_position(cube, v);
                drawn.positions.insert(drawn.positions.end(), {p.x, p.y, p.z});
            }
            for (uint32_t i : cube.data->indices) drawn.triangles.push_back(first + i);
            cube_of.insert(cube_of.end(), cube.data->triangle_count(), c);
        }
        const TriangleTree drawn_tree(drawn.view(), {});

        // Forward: every sampled point of a cube's triangles to the scan.
        std::map<uint32_t, double> forward;
        for (size_t t = 0; t < cube_of.size(); ++t) {
            const uint32_t* v = &drawn.triangles[3 * t];
            sample_triangle(&drawn.positions[3 * size_t(v[0])], &drawn.positions[3 * size_t(v[1])],
                            &drawn.positions[3 * size_t(v[2])], rng, [&](const double* p) {
                                double& worst = forward[cube_of[t]];
                                worst = std::max(worst, full_tree.nearest(p).distance);
                            });
        }
        // Coverage: every sampled point of the scan to the level's surface, charged to the cube whose
        // cell holds its triangle's barycenter (to both cubes when it lies on their shared face).
        std::map<uint32_t, double> coverage;
        const double size = h.cube_size(level);
        for (size_t t = 0; t < full.triangles.size(); t += 3) {
            const float* c[3];
            for (int k = 0; k < 3; ++k) c[k] = &full.positions[3 * size_t(full.triangles[t + size_t(k)])];
            double worst = 0;
            sample_triangle(c[0], c[1], c[2], rng, [&](const double* p) { worst = std::max(worst, drawn_tree.nearest(p).distance); });
            for (uint32_t corner = 0; corner < 8; ++corner) {
                std::array<uint32_t, 3> cell;
                for (int a = 0; a < 3; ++a) {
                    const double b = (double(c[0][a]) + c[1][a] + c[2][a]) / 3 / size;
                    const double nudge = (corner >> a & 1) ? 1e-6 : -1e-6;
                    cell[size_t(a)] = uint32_t(std::clamp(std::floor(b + nudge), 0.0, double((1u << level) - 1)));
                }
                auto it = by_cell.find(cell);
                ASSERT_NE(it, by_cell.end()) << "a scan triangle under no cube of level " << level;
                double& charged = coverage[it->second];
                charged = std::max(charged, worst);
            }
        }

        Tightness forward_tightness, coverage_tightness;
        for (const auto& [c, cube] : by_cell) {
            (void)c;
            const HlodNode& node = model->cubes()[cube].node;
            EXPECT_LE(forward[cube], node.error) << describe_cube(node) << ": its triangles are farther from the scan";
            EXPECT_LE(coverage[cube], node.error) << describe_cube(node) << ": the scan under it is farther from its level";
            forward_tightness.add(forward[cube], node.error);
            coverage_tightness.add(coverage[cube], node.error);
        }
        std::printf("level %u (%zu cubes): sampled / bound, forward median %.3f max %.3f, coverage median %.3f max %.3f\n",
                    level, by_cell.size(), forward_tightness.median(), forward_tightness.max(), coverage_tightness.median(),
                    coverage_tightness.max());
    }
}

TEST(ErrorBound, NoCubeOfTheRealScanIsFartherFromItThanItsBoundEitherWay) {
    if (test::bunny_hlod().empty()) GTEST_SKIP() << "data/bunny.off missing: run scripts/setup.sh";
    expect_bounded(*HlodModel::load(test::bunny_hlod()),
                   read_mesh(std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "bunny.off"));
}

TEST(ErrorBound, NoCubeOfTheRealTerrainIsFartherFromItThanItsBoundEitherWay) {
    // 192 × 192 samples of the Sangre de Cristo range at 3 arc-seconds: peaks, valleys and the plain.
    const auto dem = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "trinidad.nc";
    if (!std::filesystem::exists(dem)) GTEST_SKIP() << "data/trinidad.nc missing: run scripts/setup.sh";
    const Mesh terrain = test::read_dem_grid(dem, {.first_column = 560, .first_row = 560, .columns = 192, .rows = 192},
                                             {.variable = "", .unit = test::ElevationUnit::feet});
    test::TempDir dir;
    BuildSettings settings;
    settings.levels = 4;
    build_hlod(Mesh(terrain), dir / "terrain.hlod", settings, "trinidad.nc");
    expect_bounded(*HlodModel::load(dir / "terrain.hlod"), terrain);
}

// The full-resolution surface of a DEM as a terrain build defines it (preprocess/terrain_pyramid.h),
// read with GDAL alone: a vertex per valid sample at (column·Δx, (rows − 1 − row)·Δy, height) from the
// south-west sample, two triangles per cell split from its north-west to its south-east corner, each
// where its three corners are valid.
Mesh raster_surface(const std::filesystem::path& dem) {
    GDALAllRegister();
    std::unique_ptr<GDALDataset> d(GDALDataset::Open(dem.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
    const int w = d->GetRasterXSize(), h = d->GetRasterYSize();
    double g[6];
    d->GetGeoTransform(g);
    GDALRasterBand* band = d->GetRasterBand(1);
    std::vector<double> z(size_t(w) * size_t(h));
    EXPECT_EQ(band->RasterIO(GF_Read, 0, 0, w, h, z.data(), w, h, GDT_Float64, 0, 0), CE_None);
    int has_nodata = 0;
    const double nodata = band->GetNoDataValue(&has_nodata);
    auto valid = [&](int c, int r) { return !(has_nodata && z[size_t(r) * size_t(w) + size_t(c)] == nodata); };
    Mesh mesh;
    for (int r = 0; r < h; ++r)
        for (int c = 0; c < w; ++c)
            mesh.positions.insert(mesh.positions.end(), {float(c * g[1]), float((h - 1 - r) * -g[5]), float(z[size_t(r) * size_t(w) + size_t(c)])});
    auto at = [&](int c, int r) { return uint32_t(r * w + c); };
    for (int r = 0; r + 1 < h; ++r)
        for (int c = 0; c + 1 < w; ++c) {
            if (!valid(c, r) || !valid(c + 1, r + 1)) continue;
            if (valid(c, r + 1)) mesh.indices.insert(mesh.indices.end(), {at(c, r), at(c, r + 1), at(c + 1, r + 1)});
            if (valid(c + 1, r)) mesh.indices.insert(mesh.indices.end(), {at(c, r), at(c + 1, r + 1), at(c + 1, r)});
        }
    return mesh;
}

TEST(ErrorBound, NoCubeOfATerrainBuiltFromARealDemIsFartherFromItThanItsBoundEitherWay) {
    const auto dem = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "olinda_dem.tif";
    if (!std::filesystem::exists(dem)) GTEST_SKIP() << "data/olinda_dem.tif missing: run scripts/setup.sh";
    test::TempDir dir;
    build_terrain({dem}, dir / "olinda.hlod", {.cube_cells = 8}, "olinda_dem.tif");  // 5 levels of 111 × 111 samples
    expect_bounded(*HlodModel::load(dir / "olinda.hlod"), raster_surface(dem));
}

TEST(ErrorBound, NoCubeOfATerrainWithHolesIsFartherFromItThanItsBoundEitherWay) {
    // Rough ground, 61 × 47 samples, with a nodata block, scattered nodata pixels and a small island
    // the coarse levels drop.
    test::TempDir dir;
    test::TiffSpec spec{.width = 61, .height = 47, .type = GDT_Float32, .nodata = -9999};
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> noise(-4, 4);
    for (int r = 0; r < spec.height; ++r)
        for (int c = 0; c < spec.width; ++c) {
            const bool hole = (c >= 20 && c < 33 && r >= 8 && r < 19) || (c * 7 + r * 13) % 29 == 0 ||
                              (c >= 4 && c < 13 && r >= 28 && r < 37 && !(c >= 7 && c < 10 && r >= 31 && r < 34));
            spec.values.push_back(hole ? -9999 : 50 + 30 * std::sin(c * 0.3) * std::cos(r * 0.2) + noise(rng));
        }
    test::write_tiff(dir / "holes.tif", spec);
    build_terrain({dir / "holes.tif"}, dir / "holes.hlod", {.cube_cells = 8}, "holes.tif");
    expect_bounded(*HlodModel::load(dir / "holes.hlod"), raster_surface(dir / "holes.tif"));
}

}  // namespace
}  // namespace strata
