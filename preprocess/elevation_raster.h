// Elevation rasters (DEMs) through GDAL: one single-band raster, or several tiles of one mosaicked
// through an in-memory VRT, read by windows so that a terrain larger than memory builds out of core.
// What a terrain build needs to know of the raster comes with it: size, sample type, geotransform,
// CRS, nodata, scale and offset. Knows nothing of meshes or of the .hlod format.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace strata {

struct RasterInfo {
    std::string name;          // the file, or "A.tif + 3 more" for a mosaic
    uint64_t width = 0, height = 0;  // samples (columns, rows)
    std::string sample_type;   // GDAL's name of the band's type: "Int16", "Float32", ...
    // GDAL's geotransform: the CRS coordinates of pixel (column c, row r)'s upper-left corner are
    // (g[0] + c·g[1] + r·g[2], g[3] + c·g[4] + r·g[5]); a sample stands for its pixel's centre (c + ½, r + ½).
    std::array<double, 6> geotransform{};
    std::string crs_wkt;                // WKT2 of the horizontal CRS (and the vertical one, when compound)
    std::string crs_name;               // "WGS 84", "SIRGAS 2000 / UTM zone 25S"
    std::optional<int> epsg;            // when the CRS is (or is identified as) an EPSG one
    bool geographic = false;            // degrees of latitude and longitude, not a projected plane
    double semi_major = 0, inverse_flattening = 0;  // the CRS's ellipsoid (metres; 0 for a sphere)
    double linear_unit = 1;             // metres per CRS unit of a projected CRS (0.3048 for feet)
    std::string vertical_datum;         // the vertical CRS's name when the raster declares one
    std::optional<double> nodata;       // raw value, before scale and offset; may lie outside the type's range
    double scale = 1, offset = 0;       // elevation = raw · scale + offset
    std::string unit;                   // the band's unit ("m", "ft"), empty when unstated

    // The CRS position of sample (column, row)'s centre.
    std::array<double, 2> sample_position(double column, double row) const;
    // "EPSG:4326 WGS 84", or the name alone
    std::string describe_crs() const;
};

// "EPSG:32633 WGS 84 / UTM zone 33N" for a CRS given as an authority code, WKT or PROJ string (its
// name alone when it has no EPSG code); the text itself when PROJ cannot read it.
std::string describe_crs(const std::string& crs);

// The CRS (an authority code, WKT or PROJ string) as ESRI WKT, what a .prj file beside an image holds;
// the text itself when PROJ cannot read it.
std::string crs_as_esri_wkt(const std::string& crs);

// Caps the memory GDAL keeps of raster blocks it has read (its block cache, by default a share of the
// machine's memory), so that a build stays within its own limit.
void limit_raster_cache(uint64_t bytes);

class ElevationRaster {
public:
    // Opens one raster, or several tiles as one mosaic (same CRS, sample type and resolution, on one
    // grid; GDAL's VRT joins them). `crs` (EPSG:N, a WKT or a PROJ string) stands for the CRS of files
    // that declare none (a netCDF with bare latitude and longitude) and must agree with any they do
    // declare. Throws InputError naming the file and the problem: not a raster GDAL reads, more than
    // one band, a complex sample type, no geotransform, a rotated or sheared one, no CRS (and none
    // given), tiles that do not fit together.
    static ElevationRaster open(const std::vector<std::filesystem::path>& files, const std::string& crs = {});
    ElevationRaster(ElevationRaster&&) noexcept;
    ElevationRaster& operator=(ElevationRaster&&) noexcept;
    ~ElevationRaster();

    const RasterInfo& info() const { return info_; }

    // Reads the window of `columns` × `rows` samples from (column, row), row by row, into `out` (resized):
    // elevations with scale and offset applied, as float (exact for the 8- and 16-bit types and
    // Float32; within 1 mm below 8 km otherwise), NaN where the raster has nodata (or NaN). Safe to
    // call from several threads (reads are serialised). Throws InputError naming the file and the
    // window when GDAL cannot read it (a truncated file), std::out_of_range for a window outside.
    void read(uint64_t column, uint64_t row, uint64_t columns, uint64_t rows, std::vector<float>& out) const;

private:
    struct Dataset;
    ElevationRaster(std::unique_ptr<Dataset> dataset, RasterInfo info);
    std::unique_ptr<Dataset> dataset_;
    RasterInfo info_;
};

}  // namespace strata
