// Planning an embedding (preprocess/embedding.h) on a real terrain build: a site with a wiggly boundary
// placed on a DEM gets a zone whose level follows its height above the ground, and a skirt in the
// terrain's frame that takes the raster's heights at its samples and the site's own positions at its
// boundary, faces up, and with the site's footprint covers the zone's area; bad placements are refused
// naming the site.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "preprocess/embedding.h"
#include "preprocess/georeference.h"
#include "preprocess/terrain_build.h"
#include "preprocess/terrain_heights.h"
#include "tests/support/geotiff.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

namespace fs = std::filesystem;

constexpr int kSize = 97;         // samples per side
constexpr double kSpacing = 30;   // metres (the TiffSpec default)

double dem_height(int c, int r) { return 400 + 25 * std::sin(c * 0.11) * std::cos(r * 0.07) + 0.8 * c; }

// A terrain built from a 97 × 97 DEM at 30 m, optionally with a hole of nodata.
fs::path terrain(const test::TempDir& dir, bool hole = false) {
    test::TiffSpec spec;
    spec.width = spec.height = kSize;
    spec.type = GDT_Float32;
    spec.nodata = -9999;
    for (int r = 0; r < kSize; ++r)
        for (int c = 0; c < kSize; ++c) spec.values.push_back(hole && std::abs(c - 48) < 3 && std::abs(r - 48) < 3 ? -9999 : dem_height(c, r));
    const fs::path dem = dir.path() / "dem.tif", out = dir.path() / (hole ? "hole.hlod" : "dem.hlod");
    test::write_tiff(dem, spec);
    TerrainSettings settings;
    settings.cube_cells = 8;
    build_terrain({dem}, out, settings, "dem.tif");
    return out;
}

// A fan whose boundary wiggles around (cx, cy) (model metres) with radius `radius`, `above` metres over
// the ground (read from the terrain), so the site follows the ground as a scanned platform would.
Mesh site(const TerrainSite& t, double cx, double cy, double radius, double above, uint32_t seed) {
    std::mt19937 random(seed);
    Mesh mesh;
    const int n = 90;
    auto add = [&](double x, double y) {
        const auto cell = t.georeference->raster_position(x, y, 0);
        const double ground = t.heights->at((*cell)[0], (*cell)[1]).value_or(0);
        mesh.positions.insert(mesh.positions.end(), {float(x - cx), float(y - cy), float(ground + above)});
    };
    mesh.origin = {cx, cy, 0};
    for (int i = 0; i < n; ++i) {
        const double angle = 2 * M_PI * i / n, r = radius * (0.8 + 0.4 * double(random() % 1000) / 1000);
        add(cx + r * std::cos(angle), cy + r * std::sin(angle));
    }
    add(cx, cy);
    for (uint32_t i = 0; i < uint32_t(n); ++i) mesh.indices.insert(mesh.indices.end(), {uint32_t(n), i, (i + 1) % uint32_t(n)});
    return mesh;
}

glm::dvec3 vertex(const Mesh& m, uint32_t v) {
    return {m.origin[0] + m.positions[3 * v], m.origin[1] + m.positions[3 * v + 1], m.origin[2] + m.positions[3 * v + 2]};
}

TEST(Embedding, ASkirtJoinsTheRasterToTheSiteFacingUpAndCoveringTheZone) {
    const test::TempDir dir;
    const TerrainSite t = TerrainSite::open(terrain(dir));
    const Mesh mesh = site(t, 1400, 1500, 130, 2.0, 5);
    const EmbeddingPlan plan = plan_embedding(t, mesh, glm::dmat4(1.0), "site.ply");
    EXPECT_NEAR(plan.height_difference, 2.0, 1e-3);
    EXPECT_FALSE(plan.zone_capped);
    const Mesh& skirt = plan.skirt_mesh;
    ASSERT_EQ(skirt.vertex_count(), plan.skirt.vertices.size());
    ASSERT_GT(skirt.triangle_count(), 0u);
    // Samples at the raster's heights; ring vertices at the site's positions.
    size_t samples = 0;
    for (uint32_t v = 0; v < skirt.vertex_count(); ++v) {
        const SkirtVertex& sv = plan.skirt.vertices[v];
        const glm::dvec3 at = vertex(skirt, v);
        if (sv.kind == SkirtVertex::Kind::sample) {
            EXPECT_NEAR(at.z, dem_height(int(sv.a), int(sv.b)), 1e-3) << sv.a << ", " << sv.b;
            EXPECT_NEAR(at.x, double(sv.a) * kSpacing, 1e-3);
            EXPECT_NEAR(at.y, double(kSize - 1 - sv.b) * kSpacing, 1e-3);  // rows run south
            ++samples;
        } else if (sv.kind == SkirtVertex::Kind::boundary) {
            const glm::dvec3 expected = vertex(mesh, plan.footprint.ring[size_t(sv.a)]);
            EXPECT_LT(glm::length(at - expected), 1e-3);
        }
    }
    EXPECT_GT(samples, 10u);
    // Facing up, and with the site's footprint covering the zone (areas seen from above).
    double skirt_area = 0;
    for (size_t i = 0; i < skirt.indices.size(); i += 3) {
        const glm::dvec3 a = vertex(skirt, skirt.indices[i]), b = vertex(skirt, skirt.indices[i + 1]), c = vertex(skirt, skirt.indices[i + 2]);
        const double up = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        EXPECT_GE(up, -1e-6) << "triangle " << i / 3 << " faces down";
        skirt_area += up / 2;
    }
    double site_area = 0;
    const std::vector<uint32_t>& ring = plan.footprint.ring;
    for (size_t i = 0; i < ring.size(); ++i) {
        const glm::dvec3 a = vertex(mesh, ring[i]), b = vertex(mesh, ring[(i + 1) % ring.size()]);
        site_area += (a.x * b.y - b.x * a.y) / 2;
    }
    const int64_t zone_cell = plan.zone.size;
    size_t finest_cells = 0;
    for (int64_t y = plan.zone.first_y; y < plan.zone.first_y + plan.zone.height; ++y)
        for (int64_t x = plan.zone.first_x; x < plan.zone.first_x + plan.zone.width; ++x)
            if (plan.zone.at(x, y) != CellCover::none)
                finest_cells += size_t(std::min(zone_cell, kSize - 1 - x * zone_cell) * std::min(zone_cell, kSize - 1 - y * zone_cell));
    EXPECT_NEAR(skirt_area + std::abs(site_area), double(finest_cells) * kSpacing * kSpacing, 1e-3 * double(finest_cells));
}

TEST(Embedding, TheZoneIsCoarserTheHigherTheSiteRisesAboveTheGround) {
    const test::TempDir dir;
    const TerrainSite t = TerrainSite::open(terrain(dir));
    const EmbeddingPlan flat = plan_embedding(t, site(t, 1400, 1500, 130, 0.0, 5), glm::dmat4(1.0), "site.ply");
    const EmbeddingPlan tall = plan_embedding(t, site(t, 1400, 1500, 130, 40.0, 5), glm::dmat4(1.0), "site.ply");
    EXPECT_EQ(flat.zone_level, t.header().max_level);  // no height difference: the finest cells
    EXPECT_LT(tall.zone_level, flat.zone_level);
    // Where the bound decides, the drop below the zone's level stays within it.
    const HlodHeader& h = t.header();
    if (!tall.zone_capped && tall.zone_level > 0) {
        EXPECT_LE(tall.height_difference, 2.0 * h.error_q * h.cube_size(tall.zone_level - 1));
    }
    if (tall.zone_level < h.max_level) {
        EXPECT_GT(tall.height_difference, 2.0 * h.error_q * h.cube_size(tall.zone_level));
    }
    // A small, much taller site is held to a zone of cells about twice its size.
    const EmbeddingPlan tower = plan_embedding(t, site(t, 1400, 1500, 40, 4000.0, 5), glm::dmat4(1.0), "site.ply");
    EXPECT_TRUE(tower.zone_capped);
    EXPECT_LE(double(tower.zone.size) * kSpacing, 2 * 2 * 1.2 * 40);
}

TEST(Embedding, AMeshOverNodataOrOffTheRasterIsRefusedNamingIt) {
    const test::TempDir dir;
    const TerrainSite t = TerrainSite::open(terrain(dir, true));
    const double middle = 48 * kSpacing;
    try {
        plan_embedding(t, site(t, middle + 100, middle, 60, 0.0, 2), glm::dmat4(1.0), "site.ply");
        FAIL() << "an embedding over nodata was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("site.ply: the embedding's zone covers a raster sample without an elevation"), std::string::npos) << e.what();
    }
    try {
        plan_embedding(t, site(t, 50, 50, 130, 0.0, 2), glm::dmat4(1.0), "site.ply");
        FAIL() << "a mesh reaching off the raster was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("site.ply: the mesh reaches outside the terrain's raster"), std::string::npos) << e.what();
    }
    EXPECT_THROW(TerrainSite::open(dir.path() / "missing.hlod"), std::runtime_error);
}

// A closed mesh (a statue on a plinth) has no boundary to join: it stands on the ground, which stays.
TEST(Embedding, AClosedMeshStandsOnTheGroundWithNothingCut) {
    const test::TempDir dir;
    const TerrainSite t = TerrainSite::open(terrain(dir));
    Mesh statue = test::icosphere(2, 20.0f);
    statue.origin = {1400, 1500, 500};
    const EmbeddingPlan plan = plan_embedding(t, statue, glm::dmat4(1.0), "statue.ply");
    EXPECT_TRUE(plan.standing);
    EXPECT_TRUE(plan.skirt_mesh.indices.empty());
    EXPECT_TRUE(plan.footprint.ring.empty());
    // With a boundary, the same place is cut.
    EXPECT_FALSE(plan_embedding(t, site(t, 1400, 1500, 130, 0.0, 5), glm::dmat4(1.0), "site.ply").standing);
}

// Samples lie where the raster position of a model point says, in the tangent frames too.
TEST(Embedding, SamplePositionsAndRasterPositionsAgreeInEveryFrame) {
    const test::TempDir dir;
    test::TiffSpec spec;
    spec.width = spec.height = 21;
    spec.type = GDT_Float32;
    for (int r = 0; r < 21; ++r)
        for (int c = 0; c < 21; ++c) spec.values.push_back(dem_height(c, r));
    spec.geotransform = {7.0, 0.001, 0, 46.0, 0, -0.001};
    spec.crs = "EPSG:4326";
    test::write_tiff(dir.path() / "geo.tif", spec);
    for (const TerrainFrameKind frame : {TerrainFrameKind::enu, TerrainFrameKind::ecef}) {
        TerrainSettings settings;
        settings.cube_cells = 8;
        settings.frame = frame;
        const fs::path out = dir.path() / ("geo" + std::to_string(int(frame)) + ".hlod");
        build_terrain({dir.path() / "geo.tif"}, out, settings, "geo.tif");
        const TerrainSite t = TerrainSite::open(out);
        for (const auto& [c, r] : {std::pair{0, 0}, {20, 0}, {7, 13}, {20, 20}}) {
            const double h = dem_height(c, r);
            const auto at = t.georeference->sample_position(c, r, h);
            const auto back = t.georeference->raster_position((*at)[0], (*at)[1], h);
            EXPECT_NEAR((*back)[0], c, 1e-6);
            EXPECT_NEAR((*back)[1], r, 1e-6);
            if (frame == TerrainFrameKind::enu) {
                EXPECT_NEAR((*at)[2], h, 1e-9);  // ecef: z tilts with distance
            }
        }
    }
}

}  // namespace
}  // namespace strata
