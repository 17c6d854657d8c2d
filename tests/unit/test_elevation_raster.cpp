// Elevation rasters through GDAL (issue 17 §1): what ElevationRaster reports and reads is checked
// against GDAL's own command-line tools (gdalinfo, gdallocationinfo) on real DEMs that set-up fetches,
// and against rasters written here with known samples; bad rasters fail naming the file.
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "preprocess/elevation_raster.h"
#include "preprocess/mesh.h"
#include "tests/support/geotiff.h"
#include "tests/support/test_meshes.h"

// g++ 12 warns of the members a designated initializer leaves to their defaults (its bug 96868):
// the rasters below are written from specs that name only what differs.
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

namespace strata {
namespace {

using test::gdal_values;
using test::gdalinfo;
using test::TiffSpec;
using test::write_tiff;

namespace fs = std::filesystem;

fs::path data_file(const char* name) { return fs::path(STRATA_SOURCE_DIR) / "data" / name; }

std::string open_error(const std::vector<fs::path>& files, const std::string& crs = {}) {
    try {
        ElevationRaster::open(files, crs);
    } catch (const InputError& e) {
        return e.what();
    }
    return "(opened)";
}

TEST(ElevationRaster, ReportsSizeTypeGeotransformAndCrsAsGdalinfoDoes) {
    const fs::path file = data_file("olinda_dem.tif");
    const ElevationRaster raster = ElevationRaster::open({file});
    const RasterInfo& info = raster.info();
    const nlohmann::json gdal = gdalinfo(file);
    EXPECT_EQ(info.width, gdal["size"][0].get<uint64_t>());
    EXPECT_EQ(info.height, gdal["size"][1].get<uint64_t>());
    EXPECT_EQ(info.sample_type, gdal["bands"][0]["type"].get<std::string>());
    for (int k = 0; k < 6; ++k) EXPECT_EQ(info.geotransform[k], gdal["geoTransform"][k].get<double>()) << k;
    EXPECT_EQ(info.nodata.has_value(), gdal["bands"][0].contains("noDataValue"));
    OGRSpatialReference ours, theirs;
    ASSERT_EQ(ours.importFromWkt(info.crs_wkt.c_str()), OGRERR_NONE);
    ASSERT_EQ(theirs.importFromWkt(gdal["coordinateSystem"]["wkt"].get<std::string>().c_str()), OGRERR_NONE);
    EXPECT_TRUE(ours.IsSame(&theirs)) << info.crs_wkt;
    EXPECT_FALSE(info.geographic);
    EXPECT_FALSE(info.epsg) << "Olinda's CRS is a bound CRS of no EPSG code";
    // A sample stands for its pixel's centre.
    const auto centre = info.sample_position(0, 0);
    EXPECT_EQ(centre[0], info.geotransform[0] + 0.5 * info.geotransform[1]);
    EXPECT_EQ(centre[1], info.geotransform[3] + 0.5 * info.geotransform[5]);
}

TEST(ElevationRaster, NamesAnEpsgCrsByCodeAndName) {
    test::TempDir dir;
    write_tiff(dir / "utm.tif", {});
    const RasterInfo info = ElevationRaster::open({dir / "utm.tif"}).info();
    EXPECT_EQ(info.epsg, 32632);
    EXPECT_EQ(info.describe_crs(), "EPSG:32632 WGS 84 / UTM zone 32N");
    write_tiff(dir / "geographic.tif", {.geotransform = {8.7, 0.001, 0, 50.8, 0, -0.001}, .crs = "EPSG:4326"});
    const RasterInfo geographic = ElevationRaster::open({dir / "geographic.tif"}).info();
    EXPECT_EQ(geographic.describe_crs(), "EPSG:4326 WGS 84");
    EXPECT_TRUE(geographic.geographic);
    EXPECT_TRUE(info.vertical_datum.empty());
    // Heights on a declared vertical datum (UTM 32N with EGM96 heights): the datum is named.
    write_tiff(dir / "compound.tif", {.crs = "EPSG:32632+5773"});
    const RasterInfo compound = ElevationRaster::open({dir / "compound.tif"}).info();
    EXPECT_EQ(compound.vertical_datum, "EGM96 height");
    EXPECT_EQ(compound.crs_name, "WGS 84 / UTM zone 32N + EGM96 height");
}

TEST(ElevationRaster, RandomSamplesEqualWhatGdalReadsThere) {
    const fs::path file = data_file("olinda_dem.tif");
    const ElevationRaster raster = ElevationRaster::open({file});
    const RasterInfo& info = raster.info();
    std::vector<float> all;
    raster.read(0, 0, info.width, info.height, all);
    std::mt19937_64 random(17);
    std::vector<std::pair<uint64_t, uint64_t>> pixels;
    for (int n = 0; n < 300; ++n) pixels.emplace_back(random() % info.width, random() % info.height);
    pixels.emplace_back(info.width - 1, info.height - 1);  // the last row and column too
    const std::vector<double> gdal = gdal_values(file, pixels);
    ASSERT_EQ(gdal.size(), pixels.size());
    for (size_t n = 0; n < pixels.size(); ++n) {
        const auto [column, row] = pixels[n];
        EXPECT_EQ(all[row * info.width + column], float(gdal[n])) << column << ", " << row;
        std::vector<float> one;  // a window of one sample reads the same
        raster.read(column, row, 1, 1, one);
        EXPECT_EQ(one[0], all[row * info.width + column]);
    }
}

TEST(ElevationRaster, ANetcdfOfBareLatitudesAndLongitudesTakesTheCrsGivenAndItsFillValueIsNodata) {
    const fs::path file = data_file("trinidad.nc");
    EXPECT_NE(open_error({file}).find("no CRS"), std::string::npos) << open_error({file});
    const ElevationRaster raster = ElevationRaster::open({file}, "EPSG:4326");
    const RasterInfo& info = raster.info();
    EXPECT_EQ(info.epsg, 4326);
    EXPECT_TRUE(info.geographic);
    ASSERT_TRUE(info.nodata);
    EXPECT_EQ(*info.nodata, -999);
    // Rows across the raster: every sample is GDAL's value, or NaN where GDAL reads the fill value.
    std::vector<std::pair<uint64_t, uint64_t>> pixels;
    std::vector<float> window;
    std::vector<float> read;
    for (uint64_t row = 0; row < info.height; row += 97)
        for (uint64_t column = 0; column < info.width; column += 131) pixels.emplace_back(column, row);
    for (const auto& [column, row] : pixels) {
        raster.read(column, row, 1, 1, window);
        read.push_back(window[0]);
    }
    const std::vector<double> gdal = gdal_values(file, pixels);
    ASSERT_EQ(gdal.size(), pixels.size());
    for (size_t n = 0; n < pixels.size(); ++n) {
        if (gdal[n] == -999) EXPECT_TRUE(std::isnan(read[n]));
        else EXPECT_EQ(read[n], float(gdal[n]));
    }
}

TEST(ElevationRaster, NodataScaleAndOffsetApplyToTheRawSamples) {
    test::TempDir dir;
    // Raw −32768 is nodata; the rest are decimetres above 100 m.
    write_tiff(dir / "dm.tif", {.values = {0, 10, -32768, 25, 1, 2, 3, -32768, 7, 8, 9, 10}, .nodata = -32768, .scale = 0.1, .offset = 100});
    const ElevationRaster raster = ElevationRaster::open({dir / "dm.tif"});
    std::vector<float> v;
    raster.read(0, 0, 4, 3, v);
    ASSERT_EQ(v.size(), 12u);
    EXPECT_EQ(v[0], float(0 * 0.1 + 100));
    EXPECT_EQ(v[1], float(10 * 0.1 + 100));
    EXPECT_TRUE(std::isnan(v[2]));
    EXPECT_TRUE(std::isnan(v[7]));
    EXPECT_EQ(v[3], float(25 * 0.1 + 100));
    EXPECT_EQ(std::count_if(v.begin(), v.end(), [](float x) { return std::isnan(x); }), 2);
    // A window reads its own part, row by row.
    raster.read(1, 1, 2, 2, v);
    EXPECT_EQ(v, (std::vector<float>{float(2 * 0.1 + 100), float(3 * 0.1 + 100), float(8 * 0.1 + 100), float(9 * 0.1 + 100)}));
    EXPECT_THROW(raster.read(3, 0, 2, 1, v), std::out_of_range);
    // A nodata value outside the type's range (a Byte DTM with −9999) matches no sample.
    write_tiff(dir / "byte.tif", {.type = GDT_Byte, .values = {0, 255, 7}, .nodata = -9999});
    const ElevationRaster bytes = ElevationRaster::open({dir / "byte.tif"});
    EXPECT_EQ(bytes.info().nodata, -9999);
    bytes.read(0, 0, 3, 1, v);
    EXPECT_EQ(v, (std::vector<float>{0, 255, 7}));
}

TEST(ElevationRaster, TilesOnOneGridReadAsTheRasterTheyWereCutFrom) {
    const fs::path file = data_file("olinda_dem.tif");
    const ElevationRaster whole = ElevationRaster::open({file});
    test::TempDir dir;
    // Four tiles of unequal sizes, cut with gdal_translate.
    const uint64_t w = whole.info().width, h = whole.info().height, cx = 40, cy = 70;
    std::vector<fs::path> tiles;
    for (const auto& [x, y, tw, th] : std::vector<std::array<uint64_t, 4>>{{0, 0, cx, cy}, {cx, 0, w - cx, cy}, {0, cy, cx, h - cy}, {cx, cy, w - cx, h - cy}}) {
        tiles.push_back(dir / ("tile" + std::to_string(tiles.size()) + ".tif"));
        test::run_and_capture("GDAL_PAM_ENABLED=NO gdal_translate -q -srcwin " + std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(tw) +
                              " " + std::to_string(th) + " '" + file.string() + "' '" + tiles.back().string() + "'");
        ASSERT_TRUE(fs::exists(tiles.back()));
    }
    std::swap(tiles[0], tiles[3]);  // in any order
    const ElevationRaster mosaic = ElevationRaster::open(tiles);
    EXPECT_EQ(mosaic.info().width, w);
    EXPECT_EQ(mosaic.info().height, h);
    EXPECT_EQ(mosaic.info().geotransform, whole.info().geotransform);
    EXPECT_NE(mosaic.info().name.find("+ 3 more"), std::string::npos);
    std::vector<float> a, b;
    whole.read(0, 0, w, h, a);
    mosaic.read(0, 0, w, h, b);
    EXPECT_EQ(a, b);
    // A tile on another grid does not join them.
    const auto& g = whole.info().geotransform;
    write_tiff(dir / "elsewhere.tif", {.type = GDT_Float32, .geotransform = {g[0] + 10, g[1], 0, g[3], 0, g[5]}, .crs = whole.info().crs_wkt});
    const std::string offset = open_error({tiles[0], dir / "elsewhere.tif"});
    EXPECT_NE(offset.find("elsewhere.tif"), std::string::npos) << offset;
    EXPECT_NE(offset.find("fraction of a pixel"), std::string::npos) << offset;
}

TEST(ElevationRaster, BadRastersFailNamingTheFileAndTheProblem) {
    test::TempDir dir;
    auto expect_error = [&](const std::vector<fs::path>& files, const std::string& problem, const std::string& crs = {}) {
        const std::string message = open_error(files, crs);
        EXPECT_NE(message.find(files.back().string()), std::string::npos) << message;
        EXPECT_NE(message.find(problem), std::string::npos) << message;
    };
    expect_error({dir / "missing.tif"}, "no such file");
    expect_error({data_file("olinda_l7.tif")}, "6 bands");
    {
        std::ofstream(dir / "text.tif") << "not a raster at all\n";
    }
    expect_error({dir / "text.tif"}, "not a raster GDAL reads");
    write_tiff(dir / "bare.tif", {.georeferenced = false, .crs = {}});
    expect_error({dir / "bare.tif"}, "no georeference");
    write_tiff(dir / "complex.tif", {.type = GDT_CInt16});
    expect_error({dir / "complex.tif"}, "CInt16");
    write_tiff(dir / "rotated.tif", {.geotransform = {500000, 30, 2, 5600000, 2, -30}});
    expect_error({dir / "rotated.tif"}, "rotated");
    write_tiff(dir / "no_crs.tif", {.crs = {}});
    expect_error({dir / "no_crs.tif"}, "no CRS");
    EXPECT_NE(open_error({dir / "no_crs.tif"}, "EPSG:999999999").find("--crs EPSG:999999999: not a CRS"), std::string::npos);
    expect_error({data_file("olinda_dem.tif"), dir / "no_crs.tif"}, "no CRS");
    write_tiff(dir / "wgs.tif", {.crs = "EPSG:4326"});
    expect_error({dir / "wgs.tif"}, "not the one given", "EPSG:32632");
    // A truncated file opens (its header is whole) but its samples cannot be read: the read says so.
    write_tiff(dir / "big.tif", {.width = 512, .height = 512, .values = std::vector<double>(512 * 512, 42.0)});
    const auto bytes = test::file_bytes(dir / "big.tif");
    {
        std::ofstream cut(dir / "truncated.tif", std::ios::binary);
        cut.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size() / 3));
    }
    try {
        const ElevationRaster truncated = ElevationRaster::open({dir / "truncated.tif"});
        std::vector<float> v;
        truncated.read(0, 0, 512, 512, v);
        FAIL() << "a truncated raster was read whole";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("truncated.tif"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace strata
