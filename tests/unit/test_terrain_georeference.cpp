// A terrain knows where it is (issue 17 §3, preprocess/georeference.h, preprocess/terrain_heights.h):
// `height_at` gives the raster's own values (what GDAL reads) at sample centres, bilinear between them,
// nothing outside or on nodata, in every frame, streamed or loaded whole; `to_geo` and `to_local` agree
// with PROJ, independently driven, and round-trip; corrupt heights fail naming the file.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <random>

#include <glm/gtc/matrix_transform.hpp>
#include <proj.h>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "nodes/hlod_model.h"
#include "preprocess/georeference.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/terrain_build.h"
#include "preprocess/terrain_heights.h"
#include "tests/support/geotiff.h"
#include "tests/support/test_meshes.h"

#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

namespace strata {
namespace {

namespace fs = std::filesystem;

void build(const fs::path& dem, const fs::path& out, TerrainSettings settings = {}) {
    build_terrain({dem}, out, settings, dem.filename().string());
}

// Rough ground with every sample distinct, on multiples of `step`, and with `holes` a few nodata
// samples (value -9999).
std::vector<double> ground(int width, int height, double step, uint32_t seed, bool holes = true) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> noise(-3, 3);
    std::vector<double> values;
    for (int r = 0; r < height; ++r)
        for (int c = 0; c < width; ++c) {
            const double h = 900 + 60 * std::sin(c * 0.19) * std::cos(r * 0.13) + 1.7 * c + noise(rng);
            values.push_back(holes && rng() % 23 == 0 ? -9999 : std::round(h / step) * step);
        }
    return values;
}

// PROJ's transformation between two CRSs, longitude (easting) first.
class ProjTransform {
public:
    ProjTransform(const char* from, const char* to)
        : context_(proj_context_create()), raw_(proj_create_crs_to_crs(context_, from, to, nullptr)),
          pj_(raw_ ? proj_normalize_for_visualization(context_, raw_) : nullptr) {}
    ~ProjTransform() { proj_destroy(pj_), proj_destroy(raw_), proj_context_destroy(context_); }
    std::array<double, 2> operator()(double x, double y) const {
        const PJ_COORD c = proj_trans(pj_, PJ_FWD, proj_coord(x, y, 0, 0));
        return {c.xy.x, c.xy.y};
    }

private:
    PJ_CONTEXT* context_;
    PJ* raw_;
    PJ* pj_;
};

// A projected DEM of integers with scale and offset (decimetres above 100 m), and one of floats: at
// every one of 300 random samples `height_at` (model loaded whole, and streamed) is what gdallocationinfo
// reads, exactly for integers, within half a millimetre for floats; nothing on nodata; between samples
// the bilinear mean; nothing outside; every coordinate round-trips through to_geo and agrees with PROJ.
TEST(TerrainGeoreference, HeightsAreTheRastersValuesAtSampleCentresAndBilinearBetween) {
    for (const GDALDataType type : {GDT_Int16, GDT_Float32}) {
        SCOPED_TRACE(type == GDT_Int16 ? "Int16" : "Float32");
        test::TempDir dir;
        const bool integers = type == GDT_Int16;
        test::TiffSpec spec{.width = 301, .height = 277, .type = type, .geotransform = {452000, 25, 0, 5170000, 0, -25}, .crs = "EPSG:32632",
                            .nodata = -9999};
        if (integers) spec.scale = 0.1, spec.offset = 100;
        spec.values = ground(spec.width, spec.height, integers ? 1 : 0.0001, 5);
        if (integers)
            for (double& v : spec.values) v = v == -9999 ? v : std::round((v - 100) / 0.1);
        test::write_tiff(dir / "dem.tif", spec);
        build(dir / "dem.tif", dir / "dem.hlod", {.cube_cells = 32});
        EXPECT_NO_THROW(verify_hlod(HlodFile(dir / "dem.hlod")));

        const auto whole = HlodModel::load(dir / "dem.hlod");
        const auto streamed = HlodModel::open(dir / "dem.hlod");
        ASSERT_NE(whole->georeference(), nullptr);
        std::mt19937 rng(11);
        std::vector<std::pair<uint64_t, uint64_t>> pixels;
        for (int s = 0; s < 300; ++s) pixels.emplace_back(rng() % uint64_t(spec.width), rng() % uint64_t(spec.height));
        const std::vector<double> gdal = test::gdal_values(dir / "dem.tif", pixels);
        ASSERT_EQ(gdal.size(), pixels.size());
        const ProjTransform to_wgs84("EPSG:32632", "EPSG:4326");
        auto model_xy = [&](double c, double r) { return std::array{c * 25, (spec.height - 1 - r) * 25}; };
        int nodata = 0;
        for (size_t s = 0; s < pixels.size(); ++s) {
            const auto [c, r] = pixels[s];
            const auto [x, y] = model_xy(double(c), double(r));
            for (const auto& model : {whole, streamed}) {
                const std::optional<double> h = model->height_at(x, y);
                if (gdal[s] == -9999) {
                    EXPECT_FALSE(h) << "nodata at " << c << ", " << r;
                    continue;
                }
                ASSERT_TRUE(h) << "sample " << c << ", " << r;
                const double want = gdal[s] * spec.scale + spec.offset;
                EXPECT_NEAR(*h, want, integers ? 1e-9 : 0.5e-3 + 1e-6) << "sample " << c << ", " << r;
            }
            nodata += gdal[s] == -9999;
            // The sample's CRS position as GDAL's geotransform puts it, in longitude and latitude by PROJ.
            const double easting = 452000 + (double(c) + 0.5) * 25, northing = 5170000 - (double(r) + 0.5) * 25;
            const std::array<double, 2> lonlat = to_wgs84(easting, northing);
            const std::array<double, 3> geo = whole->georeference()->to_geo({x, y, 7});
            EXPECT_NEAR(geo[0], lonlat[0], 1e-10);
            EXPECT_NEAR(geo[1], lonlat[1], 1e-10);
            EXPECT_EQ(geo[2], 7);
            const std::array<double, 3> back = whole->georeference()->to_local(geo);
            EXPECT_NEAR(back[0], x, 1e-6);
            EXPECT_NEAR(back[1], y, 1e-6);
            const std::array<double, 3> in_crs = whole->georeference()->to_geo({x, y, 0}, "EPSG:32632");
            EXPECT_NEAR(in_crs[0], easting, 1e-6);
            EXPECT_NEAR(in_crs[1], northing, 1e-6);
        }
        EXPECT_GT(nodata, 0);
        // Between samples: the bilinear mean of the four around, where all four have heights.
        int checked = 0;
        for (int s = 0; s < 200; ++s) {
            const uint64_t c = rng() % uint64_t(spec.width - 1), r = rng() % uint64_t(spec.height - 1);
            const double u = double(rng() % 1000) / 1000, v = double(rng() % 1000) / 1000;
            double corner[4];
            bool valid = true;
            for (int k = 0; k < 4; ++k) {
                const double raw = spec.values[size_t((r + (k >> 1)) * uint64_t(spec.width) + c + (k & 1))];
                valid = valid && raw != -9999;
                corner[k] = raw * spec.scale + spec.offset;
            }
            const auto [x, y] = model_xy(double(c) + u, double(r) + v);
            const std::optional<double> h = whole->height_at(x, y);
            if (!valid) continue;
            ++checked;
            const double want = (1 - u) * (1 - v) * corner[0] + u * (1 - v) * corner[1] + (1 - u) * v * corner[2] + u * v * corner[3];
            ASSERT_TRUE(h);
            EXPECT_NEAR(*h, want, 1e-3);
        }
        EXPECT_GT(checked, 100);
        EXPECT_FALSE(whole->height_at(-1, 10));
        EXPECT_FALSE(whole->height_at(10, 277 * 25.0));
        EXPECT_FALSE(whole->height_at(NAN, 10));
    }
}

// A DEM in degrees over the Alps: 161 × 121 samples 0.004° apart from 10° E, 46.5° N, WGS 84.
test::TiffSpec alps_dem(const fs::path& file) {
    test::TiffSpec spec{.width = 161, .height = 121, .type = GDT_Float32, .geotransform = {10.0, 0.004, 0, 46.5, 0, -0.004}, .crs = "EPSG:4326"};
    spec.values = ground(spec.width, spec.height, 0.0001, 9, false);
    test::write_tiff(file, spec);
    return spec;
}

// At 100 random samples of alps_dem: at the model position `place` gives a sample's longitude,
// latitude and height, height_at gives its height (within `tolerance`), to_geo its longitude and
// latitude (1e-9°, 0.1 mm) and height, and to_local returns to the position.
void expect_samples_found(const HlodModel& model, const test::TiffSpec& spec, double tolerance, uint32_t seed,
                          const std::function<std::array<double, 3>(double lon, double lat, double height)>& place) {
    const Georeference& geo = *model.georeference();
    std::mt19937 rng(seed);
    for (int s = 0; s < 100; ++s) {
        const int c = int(rng() % 161), r = int(rng() % 121);
        const double lon = 10.0 + 0.004 * (c + 0.5), lat = 46.5 - 0.004 * (r + 0.5), height = spec.values[size_t(r * 161 + c)];
        const std::array<double, 3> p = place(lon, lat, height);
        const std::optional<double> h = model.height_at(p[0], p[1]);
        ASSERT_TRUE(h) << "sample " << c << ", " << r;
        EXPECT_NEAR(*h, height, tolerance) << "sample " << c << ", " << r;
        const std::array<double, 3> g = geo.to_geo(p);
        EXPECT_NEAR(g[0], lon, 1e-9);
        EXPECT_NEAR(g[1], lat, 1e-9);
        EXPECT_NEAR(g[2], height, 1e-4);
        const std::array<double, 3> back = geo.to_local(g);
        for (size_t a = 0; a < 3; ++a) EXPECT_NEAR(back[a], p[a], 1e-4);
    }
}

// A DEM in degrees, in both geographic frames: a sample's model position (PROJ's topocentric
// coordinates of its ellipsoid point, or of the point itself in ecef) gives back its height within a
// centimetre, to_geo gives its longitude and latitude within 1e-9° (0.1 mm), and to_local returns.
TEST(TerrainGeoreference, GeographicFramesFindTheirSamplesBothWays) {
    test::TempDir dir;
    const test::TiffSpec spec = alps_dem(dir / "alps.tif");
    const double lon0 = 10.0 + 0.004 * (80 + 0.5), lat0 = 46.5 - 0.004 * (60 + 0.5);
    const test::Topocentric topocentric(lon0, lat0);
    ASSERT_TRUE(topocentric.ok());
    for (const TerrainFrameKind frame : {TerrainFrameKind::enu, TerrainFrameKind::ecef}) {
        SCOPED_TRACE(frame == TerrainFrameKind::enu ? "enu" : "ecef");
        build(dir / "alps.tif", dir / "alps.hlod", {.cube_cells = 16, .frame = frame});
        expect_samples_found(*HlodModel::open(dir / "alps.hlod"), spec, 0.01, 4, [&](double lon, double lat, double height) {
            const std::array<double, 3> at_zero = topocentric(lon, lat, 0), at_height = topocentric(lon, lat, height);
            return frame == TerrainFrameKind::enu ? std::array{at_zero[0], at_zero[1], height} : at_height;
        });
    }
}

// A DEM in degrees reprojected into UTM 32N (`--frame EPSG:32632`): each sample lies where PROJ,
// driven on its own, puts its longitude and latitude in that CRS (less the model's origin, which GEOR
// holds with the CRS), within a millimetre; its height comes back there; to_geo and to_local agree;
// the model's box is the samples' own. A CRS that is not a plane in metres is refused by name.
TEST(TerrainGeoreference, AReprojectedFramePutsEverySampleWherePROJDoes) {
    test::TempDir dir;
    const test::TiffSpec spec = alps_dem(dir / "alps.tif");
    TerrainSettings settings{.cube_cells = 16};
    settings.frame_crs = "EPSG:32632";
    build(dir / "alps.tif", dir / "alps.hlod", settings);
    EXPECT_NO_THROW(verify_hlod(HlodFile(dir / "alps.hlod")));
    const auto model = HlodModel::load(dir / "alps.hlod");
    const HlodHeader& h = model->header();
    EXPECT_EQ(h.crs, "EPSG:32632");
    ASSERT_TRUE(h.terrain);
    EXPECT_EQ(h.terrain->frame, 3u);
    EXPECT_TRUE(h.terrain->raster_geographic);
    const ProjTransform utm("EPSG:4326", "EPSG:32632");
    std::array<double, 2> lo{INFINITY, INFINITY}, hi{-INFINITY, -INFINITY};
    for (int r = 0; r < spec.height; ++r)
        for (int c = 0; c < spec.width; ++c) {
            const std::array<double, 2> e = utm(10.0 + 0.004 * (c + 0.5), 46.5 - 0.004 * (r + 0.5));
            for (size_t a = 0; a < 2; ++a) lo[a] = std::min(lo[a], e[a] - h.geo_origin[a]), hi[a] = std::max(hi[a], e[a] - h.geo_origin[a]);
        }
    for (size_t a = 0; a < 2; ++a) {
        EXPECT_NEAR(h.bounds_lo[a], lo[a], 1e-3) << "axis " << a;
        EXPECT_NEAR(h.bounds_hi[a], hi[a], 1e-3) << "axis " << a;
    }
    expect_samples_found(*model, spec, 0.001, 5, [&](double lon, double lat, double height) {
        const std::array<double, 2> e = utm(lon, lat);
        return std::array{e[0] - h.geo_origin[0], e[1] - h.geo_origin[1], height};
    });
    EXPECT_FALSE(model->height_at(hi[0] + 500, 0)) << "east of the raster";
    for (const auto& [crs, words] : {std::pair{"EPSG:4326", "not a projected CRS"}, std::pair{"EPSG:2272", "a projected CRS not in metres"},
                                     std::pair{"no such crs", "not a CRS PROJ knows"}}) {
        settings.frame_crs = crs;
        try {
            build(dir / "alps.tif", dir / "bad.hlod", settings);
            ADD_FAILURE() << "built in " << crs;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(std::string("--frame ") + crs + ": " + words), std::string::npos) << e.what();
        }
        EXPECT_FALSE(fs::exists(dir / "bad.hlod"));
    }
}

// A grid in degrees that starts at 359.8° and runs past 360° (0 … 360° grids are common in netCDF):
// every sample is found again from the model position of its longitude, wherever the longitude wraps.
TEST(TerrainGeoreference, LongitudesPastTheAntimeridianOfTheGridStillFindTheirSamples) {
    test::TempDir dir;
    test::TiffSpec spec{.width = 101, .height = 41, .type = GDT_Float32, .geotransform = {359.8, 0.004, 0, 46.5, 0, -0.004}, .crs = "EPSG:4326"};
    spec.values = ground(spec.width, spec.height, 0.001, 6, false);
    test::write_tiff(dir / "wrap.tif", spec);
    build(dir / "wrap.tif", dir / "wrap.hlod", {.cube_cells = 16});
    const auto model = HlodModel::open(dir / "wrap.hlod");
    for (int c = 0; c < spec.width; c += 5)
        for (int r = 0; r < spec.height; r += 8) {
            const double lon = 359.8 + 0.004 * (c + 0.5), lat = 46.5 - 0.004 * (r + 0.5);
            for (const double given : {lon, lon - 360}) {  // 360.1° and 0.1° are one meridian
                const std::array<double, 3> at = model->georeference()->to_local({given, lat, 0});
                const std::optional<double> h = model->height_at(at[0], at[1]);
                ASSERT_TRUE(h) << "sample " << c << ", " << r << " at longitude " << given;
                EXPECT_NEAR(*h, spec.values[size_t(r * spec.width + c)], 0.001) << "sample " << c << ", " << r;
            }
        }
}

// A byte changed in a block of heights: reading a height there, and `strata verify`, fail naming the
// file; a model without a CRS has no georeference and says so when asked for heights.
TEST(TerrainGeoreference, CorruptHeightsFailNamingTheFile) {
    test::TempDir dir;
    test::TiffSpec spec{.width = 40, .height = 30, .type = GDT_Float32, .geotransform = {452000, 25, 0, 5170000, 0, -25}, .crs = "EPSG:32632"};
    spec.values = ground(spec.width, spec.height, 0.0001, 2, false);
    test::write_tiff(dir / "dem.tif", spec);
    build(dir / "dem.tif", dir / "dem.hlod", {.cube_cells = 64});
    uint64_t block_at = 0;
    {
        const HlodFile file(dir / "dem.hlod");
        const HlodSection* heights = file.find_section(kHeightsTag);
        ASSERT_NE(heights, nullptr);
        block_at = heights->offset + heights->size - 5;  // inside the last (only) block's zstd frame
    }
    std::fstream f(dir / "dem.hlod", std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(block_at));
    const char byte = char(f.get() ^ 0x40);
    f.seekp(std::streamoff(block_at));
    f.put(byte);
    f.close();
    const auto model = HlodModel::open(dir / "dem.hlod");
    try {
        model->height_at(100, 100);
        ADD_FAILURE() << "a corrupt block was read";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find((dir / "dem.hlod").string()), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("heights block 0 0"), std::string::npos) << e.what();
    }
    EXPECT_THROW(verify_hlod(HlodFile(dir / "dem.hlod")), std::runtime_error);

    BuildSettings settings;
    settings.threads = 1;
    build_hlod(test::icosphere(2), dir / "sphere.hlod", settings, "sphere.ply");
    const auto sphere = HlodModel::open(dir / "sphere.hlod");
    EXPECT_EQ(sphere->georeference(), nullptr);
    try {
        sphere->height_at(0, 0);
        ADD_FAILURE() << "heights of a mesh";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("not a terrain"), std::string::npos) << e.what();
    }
}

// No float32 jitter on a continental terrain: a camera 1 m above the ground 900 km from the model's
// origin (a strip of ground 910 km long at 100 m) sees the ground near it as it sees the same samples
// built into a small model of their own (9 × 9 samples around the spot, placed where they lie). Drawn
// positions are measured from the eye (HlodModel::LatticeAnchor) and the transform to the screen adds
// the distance in double, so the two depth images agree to float rounding; measured from the origin,
// float's step there (6 cm) moves the ground a metre below the eye by per cents.
TEST(TerrainGeoreference, ACamera900KmFromTheOriginSeesTheGroundAsASmallModelShowsIt) {
    test::TempDir dir;
    test::TiffSpec spec{.width = 9100, .height = 16, .type = GDT_Float32, .geotransform = {100000, 100, 0, 5900000, 0, -100}, .crs = "EPSG:3857"};
    // Level ground: every sample lies exactly on both models' lattices (steps of 100·8/2^15 m from
    // their south-west samples, at the lowest height), so the two draw the very same triangles and
    // only the arithmetic of drawing them can differ.
    auto height = [](int, int) { return 300.0; };
    for (int r = 0; r < spec.height; ++r)
        for (int c = 0; c < spec.width; ++c) spec.values.push_back(height(c, r));
    test::write_tiff(dir / "continent.tif", spec);
    // Columns 8996…9004 and rows 4…12 (from the north): the spot's cell and four around it each way.
    test::TiffSpec crop = spec;
    crop.width = crop.height = 9;
    crop.geotransform[0] += 8996 * 100, crop.geotransform[3] -= 4 * 100;
    crop.values.clear();
    for (int r = 4; r < 13; ++r)
        for (int c = 8996; c < 9005; ++c) crop.values.push_back(height(c, r));
    test::write_tiff(dir / "spot.tif", crop);
    build(dir / "continent.tif", dir / "continent.hlod", {.cube_cells = 8});
    build(dir / "spot.tif", dir / "spot.hlod", {.cube_cells = 8});
    const auto context = gl::create_headless_context();
    const auto continent = HlodModel::load(dir / "continent.hlod"), spot = HlodModel::load(dir / "spot.hlod");
    continent->set_pixel_error(0.5), spot->set_pixel_error(0.5);
    const glm::dvec2 at(900000.5, 700.25);  // in the continent's frame: 900 km east of its origin
    const double ground = *continent->height_at(at.x, at.y), ahead = *continent->height_at(at.x + 12, at.y + 5);
    Camera camera;
    camera.width = 160, camera.height = 120;
    camera.near_clip = 0.05, camera.far_clip = 5000;
    camera.look_at({at.x, at.y, ground + 1}, {at.x + 12, at.y + 5, ahead}, {0, 0, 1});

    auto depth_seen = [&](const std::shared_ptr<HlodModel>& model, const glm::dvec3& placed_at) {
        auto scene = std::make_shared<Group>();
        auto place = std::make_shared<Transform>();
        place->set_matrix(glm::translate(glm::dmat4(1.0), placed_at));
        place->add(model);
        scene->add(place);
        gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
        Renderer().render(*scene, camera, target);
        return target.read_depth();
    };
    // The crop's south-west sample (column 8996, row 12) lies at x = 8996·100, y = (15 − 12)·100.
    const std::vector<float> far = depth_seen(continent, glm::dvec3(0.0)), near = depth_seen(spot, {899600.0, 300.0, 0.0});
    ASSERT_EQ(far.size(), near.size());
    size_t compared = 0;
    double worst = 0;
    for (size_t p = 0; p < far.size(); ++p) {
        if (near[p] < 0.05f / 200) continue;  // reversed Z (near / depth): ground within 200 m, well inside the crop
        ++compared;
        worst = std::max(worst, std::abs(double(far[p]) - double(near[p])) / double(near[p]));
    }
    EXPECT_GT(compared, far.size() / 4) << "the near ground fills the lower part of the view";
    EXPECT_LT(worst, 1e-4) << "the ground 900 km from the origin is not where the small model puts it";
    std::printf("900 km from the origin: depth within %.2g of the small model's over %zu pixels\n", worst, compared);
}

}  // namespace
}  // namespace strata
