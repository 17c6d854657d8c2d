// ElevationRaster: GDAL's datasets behind the window reads a terrain build makes.
#include "preprocess/elevation_raster.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>

#include "preprocess/gdal_dataset.h"
#include "preprocess/mesh.h"

namespace strata {

namespace {

// The CRS's EPSG code, when it has one or PROJ identifies it as one.
std::optional<int> epsg_code(const OGRSpatialReference& reference) {
    OGRSpatialReference identified(reference);
    QuietGdal quiet;
    const char* authority = identified.GetAuthorityName(nullptr);
    if (!authority) identified.AutoIdentifyEPSG(), authority = identified.GetAuthorityName(nullptr);
    if (authority && std::string(authority) == "EPSG")
        if (const char* code = identified.GetAuthorityCode(nullptr)) return std::atoi(code);
    return std::nullopt;
}

// A CRS given as text (EPSG:N, WKT, a PROJ string), read without GDAL printing; none when PROJ cannot
// read it (QuietGdal::last() then says why).
std::optional<OGRSpatialReference> read_crs(const std::string& crs) {
    register_gdal_drivers();
    OGRSpatialReference reference;
    reference.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    QuietGdal quiet;
    if (reference.SetFromUserInput(crs.c_str()) != OGRERR_NONE) return std::nullopt;
    return reference;
}

// The CRS named by the user: what stands for files that declare none.
OGRSpatialReference crs_named(const std::string& crs) {
    std::optional<OGRSpatialReference> reference = read_crs(crs);
    if (!reference) throw InputError("--crs " + crs + ": not a CRS PROJ knows" + QuietGdal::last());
    return *reference;
}

// "EPSG:32633 WGS 84 / UTM zone 33N", or the name alone.
std::string crs_label(std::optional<int> epsg, const std::string& name) {
    return epsg ? "EPSG:" + std::to_string(*epsg) + " " + name : name;
}

// One file's raster, checked as a DEM: one band of real samples, an upright geotransform, a CRS.
struct Tile {
    std::filesystem::path file;
    DatasetPtr dataset;
    std::array<double, 6> geotransform{};
    OGRSpatialReference crs;
};

Tile open_tile(const std::filesystem::path& file, const std::optional<OGRSpatialReference>& given_crs) {
    Tile tile;
    tile.file = file;
    tile.dataset = open_dataset(file);
    GDALDataset& d = *tile.dataset;
    const std::string name = file.string();
    if (d.GetRasterCount() != 1)
        throw InputError(name + ": " + std::to_string(d.GetRasterCount()) +
                         " bands; an elevation raster has one (take the elevation band alone, e.g. gdal_translate -b 1)");
    const GDALDataType type = d.GetRasterBand(1)->GetRasterDataType();
    if (GDALDataTypeIsComplex(type) || type == GDT_Unknown)
        throw InputError(name + ": its samples are " + GDALGetDataTypeName(type) + "; elevations are real numbers");
    if (d.GetRasterXSize() < 2 || d.GetRasterYSize() < 2)
        throw InputError(name + ": " + std::to_string(d.GetRasterXSize()) + " x " + std::to_string(d.GetRasterYSize()) +
                         " samples; a terrain needs at least 2 x 2");
    if (d.GetGeoTransform(tile.geotransform.data()) != CE_None)
        throw InputError(name + ": no georeference (no geotransform): the raster does not say where its samples lie");
    const auto& g = tile.geotransform;
    if (g[2] != 0 || g[4] != 0)
        throw InputError(name + ": a rotated or sheared geotransform; warp it upright first (gdalwarp)");
    if (!(g[1] > 0) || g[5] == 0 || !std::isfinite(g[0]) || !std::isfinite(g[3]) || !std::isfinite(g[5]))
        throw InputError(name + ": a geotransform with pixel size " + std::to_string(g[1]) + " x " + std::to_string(g[5]));
    if (const OGRSpatialReference* declared = d.GetSpatialRef()) {
        tile.crs = *declared;
        tile.crs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
        if (given_crs && !tile.crs.IsSame(&*given_crs))
            throw InputError(name + ": declares the CRS " + (tile.crs.GetName() ? tile.crs.GetName() : "?") + ", not the one given (--crs)");
    } else if (given_crs) {
        tile.crs = *given_crs;
    } else {
        throw InputError(name + ": no CRS; name the one its coordinates are in (--crs EPSG:N)");
    }
    return tile;
}

// A mosaic's tiles must share a grid: same CRS, sample type, nodata and pixel size, with origins
// whole pixels apart, so that the VRT places each sample where its file says, unresampled.
void check_tiles_fit(const std::vector<Tile>& tiles) {
    const Tile& first = tiles.front();
    GDALRasterBand& band = *first.dataset->GetRasterBand(1);
    int has = 0;
    const double nodata = band.GetNoDataValue(&has);
    for (size_t t = 1; t < tiles.size(); ++t) {
        const Tile& tile = tiles[t];
        const std::string pair = tile.file.string() + " and " + first.file.string();
        GDALRasterBand& other = *tile.dataset->GetRasterBand(1);
        if (!tile.crs.IsSame(&first.crs)) throw InputError(pair + ": different CRSs; a mosaic's tiles share one");
        if (other.GetRasterDataType() != band.GetRasterDataType())
            throw InputError(pair + ": different sample types (" + GDALGetDataTypeName(other.GetRasterDataType()) + ", " +
                             GDALGetDataTypeName(band.GetRasterDataType()) + ")");
        int other_has = 0;
        const double other_nodata = other.GetNoDataValue(&other_has);
        if (other_has != has || (has && !(other_nodata == nodata || (std::isnan(other_nodata) && std::isnan(nodata)))))
            throw InputError(pair + ": different nodata values");
        const auto& g = tile.geotransform;
        const auto& f = first.geotransform;
        if (std::abs(g[1] - f[1]) > 1e-9 * std::abs(f[1]) || std::abs(g[5] - f[5]) > 1e-9 * std::abs(f[5]))
            throw InputError(pair + ": different resolutions; resample one onto the other's grid first (gdalwarp -tr)");
        const double dx = (g[0] - f[0]) / f[1], dy = (g[3] - f[3]) / f[5];
        if (std::abs(dx - std::round(dx)) > 1e-6 || std::abs(dy - std::round(dy)) > 1e-6)
            throw InputError(pair + ": their grids are offset by a fraction of a pixel; a mosaic's samples must line up");
    }
}

std::string mosaic_name(const std::vector<std::filesystem::path>& files) {
    return files.size() == 1 ? files.front().string() : files.front().string() + " + " + std::to_string(files.size() - 1) + " more";
}

}  // namespace

struct ElevationRaster::Dataset {
    std::vector<Tile> tiles;  // kept open: the VRT reads through them
    DatasetPtr mosaic;        // the VRT over several tiles; none for one file
    mutable std::mutex mutex;  // a GDAL dataset is not to be read by two threads at once

    // What reads go to: the one file, or the mosaic of them.
    GDALDataset& whole() const { return mosaic ? *mosaic : *tiles.front().dataset; }
    GDALRasterBand& band() const { return *whole().GetRasterBand(1); }
};

std::array<double, 2> RasterInfo::sample_position(double column, double row) const {
    const auto& g = geotransform;
    const double c = column + 0.5, r = row + 0.5;
    return {g[0] + c * g[1] + r * g[2], g[3] + c * g[4] + r * g[5]};
}

std::string crs_as_esri_wkt(const std::string& crs) {
    const std::optional<OGRSpatialReference> reference = read_crs(crs);
    if (!reference) return crs;
    char* wkt = nullptr;
    const char* options[] = {"FORMAT=WKT1_ESRI", nullptr};
    std::string text = reference->exportToWkt(&wkt, options) == OGRERR_NONE && wkt ? wkt : crs;
    CPLFree(wkt);
    return text;
}

void limit_raster_cache(uint64_t bytes) { GDALSetCacheMax64(GIntBig(std::min<uint64_t>(bytes, uint64_t(1) << 62))); }

std::string describe_crs(const std::string& crs) {
    const std::optional<OGRSpatialReference> reference = read_crs(crs);
    if (!reference) return crs;
    return crs_label(epsg_code(*reference), reference->GetName() ? reference->GetName() : "unnamed CRS");
}

std::string RasterInfo::describe_crs() const { return crs_label(epsg, crs_name); }

ElevationRaster ElevationRaster::open(const std::vector<std::filesystem::path>& files, const std::string& crs) {
    if (files.empty()) throw std::invalid_argument("ElevationRaster::open: no files");
    register_gdal_drivers();
    std::optional<OGRSpatialReference> given;
    if (!crs.empty()) given = crs_named(crs);
    auto dataset = std::make_unique<Dataset>();
    for (const auto& file : files) dataset->tiles.push_back(open_tile(file, given));
    check_tiles_fit(dataset->tiles);
    const Tile& first = dataset->tiles.front();
    RasterInfo info;
    info.name = mosaic_name(files);
    if (files.size() > 1) {
        QuietGdal quiet;
        std::vector<GDALDatasetH> handles;
        for (const Tile& tile : dataset->tiles) handles.push_back(GDALDataset::ToHandle(tile.dataset.get()));
        int usage_error = 0;
        dataset->mosaic.reset(GDALDataset::FromHandle(GDALBuildVRT("", int(handles.size()), handles.data(), nullptr, nullptr, &usage_error)));
        if (!dataset->mosaic) throw InputError(info.name + ": the tiles do not make one mosaic" + QuietGdal::last());
    }
    GDALDataset& whole = dataset->whole();
    info.width = uint64_t(whole.GetRasterXSize()), info.height = uint64_t(whole.GetRasterYSize());
    if (whole.GetGeoTransform(info.geotransform.data()) != CE_None) info.geotransform = first.geotransform;
    GDALRasterBand& band = dataset->band();
    info.sample_type = GDALGetDataTypeName(band.GetRasterDataType());
    int has = 0;
    if (const double nodata = band.GetNoDataValue(&has); has) info.nodata = nodata;
    info.scale = band.GetScale(&has);
    if (!has) info.scale = 1;
    info.offset = band.GetOffset(&has);
    if (!has) info.offset = 0;
    if (const char* unit = band.GetUnitType()) info.unit = unit;
    const OGRSpatialReference& reference = first.crs;
    char* wkt = nullptr;
    const char* wkt_options[] = {"FORMAT=WKT2_2019", nullptr};
    if (reference.exportToWkt(&wkt, wkt_options) == OGRERR_NONE && wkt) info.crs_wkt = wkt;
    CPLFree(wkt);
    info.crs_name = reference.GetName() ? reference.GetName() : "unnamed CRS";
    info.geographic = reference.IsGeographic();
    info.semi_major = reference.GetSemiMajor();
    info.inverse_flattening = reference.GetInvFlattening();
    if (reference.IsProjected()) info.linear_unit = reference.GetLinearUnits();
    info.epsg = epsg_code(reference);
    if (reference.IsCompound() || reference.IsVertical())
        if (const char* vertical = reference.GetAttrValue(reference.IsCompound() ? "COMPD_CS|VERT_CS" : "VERT_CS")) info.vertical_datum = vertical;
    return ElevationRaster(std::move(dataset), std::move(info));
}

ElevationRaster::ElevationRaster(std::unique_ptr<Dataset> dataset, RasterInfo info) : dataset_(std::move(dataset)), info_(std::move(info)) {}
ElevationRaster::ElevationRaster(ElevationRaster&&) noexcept = default;
ElevationRaster& ElevationRaster::operator=(ElevationRaster&&) noexcept = default;
ElevationRaster::~ElevationRaster() = default;

void ElevationRaster::read(uint64_t column, uint64_t row, uint64_t columns, uint64_t rows, std::vector<float>& out) const {
    if (column > info_.width || columns > info_.width - column || row > info_.height || rows > info_.height - row)
        throw std::out_of_range("ElevationRaster::read: a window outside the raster");
    out.resize(columns * rows);
    if (out.empty()) return;
    // Raw values as doubles (exact for every real type), so that nodata compares as the file wrote it,
    // even a nodata outside the type's range, which then matches nothing.
    std::vector<double> raw(out.size());
    {
        std::lock_guard lock(dataset_->mutex);
        QuietGdal quiet;
        if (dataset_->band().RasterIO(GF_Read, int(column), int(row), int(columns), int(rows), raw.data(), int(columns), int(rows),
                                     GDT_Float64, 0, 0, nullptr) != CE_None)
            throw InputError(info_.name + ": cannot read rows " + std::to_string(row) + " to " + std::to_string(row + rows - 1) +
                             ", columns " + std::to_string(column) + " to " + std::to_string(column + columns - 1) + QuietGdal::last());
    }
    for (size_t i = 0; i < raw.size(); ++i) {
        const double v = raw[i];
        const bool missing = std::isnan(v) || v == info_.nodata;  // a NaN nodata equals nothing: isnan covers it
        const double elevation = v * info_.scale + info_.offset;
        if (!missing && !(std::abs(elevation) <= std::numeric_limits<float>::max()))
            throw InputError(info_.name + ": the sample at column " + std::to_string(column + i % columns) + ", row " +
                             std::to_string(row + i / columns) + " is " + std::to_string(elevation) + ", not an elevation");
        out[i] = missing ? std::numeric_limits<float>::quiet_NaN() : float(elevation);
    }
}

}  // namespace strata
