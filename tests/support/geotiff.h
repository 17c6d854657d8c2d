// Rasters for the terrain tests: GeoTIFFs written with GDAL from known samples, and what GDAL's own
// command-line tools (gdalinfo, gdallocationinfo) report of a raster, to check Strata against.
#pragma once

#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <proj.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/test_meshes.h"

namespace strata::test {

// gdalinfo's report, without the side file (.aux.xml) it would otherwise leave beside the raster.
inline nlohmann::json gdalinfo(const std::filesystem::path& file) {
    return nlohmann::json::parse(test::run_and_capture("GDAL_PAM_ENABLED=NO gdalinfo -json '" + file.string() + "'"));
}

// The raw values gdallocationinfo reads at (column, row) pixels.
inline std::vector<double> gdal_values(const std::filesystem::path& file, const std::vector<std::pair<uint64_t, uint64_t>>& pixels, const std::string& open_as = {}) {
    test::TempDir dir;
    {
        std::ofstream list(dir / "pixels.txt");
        for (const auto& [column, row] : pixels) list << column << ' ' << row << '\n';
    }
    std::istringstream printed(test::run_and_capture("GDAL_PAM_ENABLED=NO gdallocationinfo -valonly '" + (open_as.empty() ? file.string() : open_as) +
                                                     "' < '" + (dir / "pixels.txt").string() + "'"));
    std::vector<double> values;
    for (std::string line; std::getline(printed, line);) values.push_back(std::stod(line));
    return values;
}

// A GeoTIFF written with GDAL: `values` row by row (raw), type, geotransform, CRS, nodata, scale and offset.
struct TiffSpec {
    int width = 4, height = 3, bands = 1;
    GDALDataType type = GDT_Int16;
    std::vector<double> values;  // width × height, the first band; the rest stay 0
    std::array<double, 6> geotransform{500000, 30, 0, 5600000, 0, -30};
    bool georeferenced = true;
    std::string crs = "EPSG:32632";
    std::optional<double> nodata;
    double scale = 1, offset = 0;
};

inline void write_tiff(const std::filesystem::path& file, const TiffSpec& spec) {
    GDALAllRegister();
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    ASSERT_NE(driver, nullptr);
    GDALDataset* d = driver->Create(file.c_str(), spec.width, spec.height, spec.bands, spec.type, nullptr);
    ASSERT_NE(d, nullptr);
    if (spec.georeferenced) {
        std::array<double, 6> g = spec.geotransform;
        d->SetGeoTransform(g.data());
    }
    if (!spec.crs.empty()) {
        OGRSpatialReference crs;
        crs.SetFromUserInput(spec.crs.c_str());
        d->SetSpatialRef(&crs);
    }
    GDALRasterBand* band = d->GetRasterBand(1);
    if (spec.nodata) band->SetNoDataValue(*spec.nodata);
    if (spec.scale != 1) band->SetScale(spec.scale);
    if (spec.offset != 0) band->SetOffset(spec.offset);
    std::vector<double> values = spec.values;
    values.resize(size_t(spec.width) * spec.height, 0);
    EXPECT_EQ(band->RasterIO(GF_Write, 0, 0, spec.width, spec.height, values.data(), spec.width, spec.height, GDT_Float64, 0, 0), CE_None);
    GDALClose(d);
}

// A PROJ pipeline, for the expected positions: geodetic → geocentric → east, north, up at a point.
class Topocentric {
public:
    Topocentric(double longitude, double latitude)
        : context_(proj_context_create()),
          pipeline_(proj_create(context_, ("+proj=pipeline +step +proj=cart +ellps=WGS84 +step +proj=topocentric +ellps=WGS84 +lon_0=" +
                                           exact(longitude) + " +lat_0=" + exact(latitude) + " +h_0=0")
                                              .c_str())) {}
    ~Topocentric() { proj_destroy(pipeline_), proj_context_destroy(context_); }
    std::array<double, 3> operator()(double longitude, double latitude, double height) const {
        const PJ_COORD c = proj_trans(pipeline_, PJ_FWD, proj_coord(proj_torad(longitude), proj_torad(latitude), height, 0));
        return {c.xyz.x, c.xyz.y, c.xyz.z};
    }
    bool ok() const { return pipeline_ != nullptr; }

private:
    static std::string exact(double v) {
        char text[32];
        std::snprintf(text, sizeof text, "%.17g", v);
        return text;
    }
    PJ_CONTEXT* context_;
    PJ* pipeline_;
};

}  // namespace strata::test
