// Where a georeferenced model lies on the Earth (sections GEOR, and TERR for a terrain), both ways:
// model coordinates to its CRS and to longitude, latitude and height, through PROJ for other CRSs. What
// `model:to_geo`, `model:to_local` and `model:height_at` stand on. Longitude comes first whatever a
// CRS's axis order (PROJ's normalised order); heights pass through unchanged, in the model's vertical
// datum.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "preprocess/hlod_format.h"
#include "preprocess/terrain_frame.h"

namespace strata {

// The name of a compound CRS's vertical CRS (heights above a geoid, "EGM96 height"), or "" for a CRS
// whose heights are the ellipsoid's or unsaid. Throws std::runtime_error when PROJ cannot read `crs`.
std::string vertical_datum(const std::string& crs);

class Georeference {
public:
    // `name` (the model's file) names the errors. Throws std::runtime_error when the model has no CRS.
    Georeference(const HlodHeader& header, std::string name);
    ~Georeference();
    Georeference(const Georeference&) = delete;
    Georeference& operator=(const Georeference&) = delete;

    const std::string& crs() const { return crs_; }
    // The model point's position in the model's CRS (x, y in its units; a geographic CRS: longitude and
    // latitude in degrees) and its height; and back. Exact arithmetic on GEOR's origin for a projected
    // CRS; the tangent plane's formulas (terrain_frame.h) for a terrain in the enu or ecef frame.
    std::array<double, 3> model_to_crs(const std::array<double, 3>& model) const;
    std::array<double, 3> crs_to_model(const std::array<double, 3>& crs) const;
    // Longitude, latitude (degrees) and height of a model point on the model CRS's own datum, or the
    // point's coordinates in `crs` (EPSG:N, WKT or a PROJ string; easting first); and back. Throws
    // std::runtime_error naming the CRS when PROJ cannot read it or the point lies outside what it maps.
    std::array<double, 3> to_geo(const std::array<double, 3>& model, const std::string& crs = {}) const;
    std::array<double, 3> to_local(const std::array<double, 3>& geo, const std::string& crs = {}) const;
    // A terrain's raster position (column, row; sample centres at whole numbers) of the ground point
    // under model (x, y) at `height`: the point whose model x and y these are (in the ecef frame, where
    // the up direction turns across the model, that depends on the height). Nothing for a model that is
    // not a terrain.
    std::optional<std::array<double, 2>> raster_position(double x, double y, double height) const;
    // The other way: the model position of the terrain's sample at (column, row) with `height`, where the
    // terrain's build put it (terrain_frame.h). Nothing for a model that is not a terrain; throws
    // std::runtime_error when PROJ cannot map the sample (a reprojected terrain).
    std::optional<std::array<double, 3>> sample_position(double column, double row, double height) const;

private:
    struct Proj;
    // PROJ's transformation from the model's CRS to `crs` (or to its geographic CRS), made once.
    void* transformation(const std::string& crs) const;
    std::array<double, 3> transform(const std::array<double, 3>& point, const std::string& crs, bool forward) const;

    std::string name_, crs_;
    std::array<double, 3> geo_origin_{};
    std::optional<TerrainGrid> terrain_;
    TangentPlane tangent_;  // a terrain in frame enu or ecef
    mutable std::mutex mutex_;  // PROJ's objects are not thread-safe
    std::unique_ptr<Proj> proj_;
};

}  // namespace strata
