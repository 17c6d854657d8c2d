// Where a terrain's samples go in its model (issue 17): x east, y north, z up, in metres, whatever the
// raster's CRS.
//
// - A projected CRS in metres: the CRS's own plane, moved so that the south-west sample is at x = y = 0
//   (GEOR: geo_origin + (x, y) is the CRS position). Exact: the grid stays a regular grid.
// - A geographic CRS (degrees), on the CRS's ellipsoid, heights taken as above it. A sample at
//   longitude λ, latitude φ and height h has geocentric coordinates P(h) = ((N + h) cos φ cos λ,
//   (N + h) cos φ sin λ, (N (1 − e²) + h) sin φ), N = a / √(1 − e² sin² φ); E, N, U are the east, north
//   and up directions at the raster's centre C = P₀ there.
//   * enu (the default): the tangent plane at the centre, flat: x = E·(P(0) − C), y = N·(P(0) − C),
//     z = h. The ground is drawn onto the plane straight down its normal, so distances from the centre
//     shrink by about (d/R)²/2: 3·10⁻⁵ at 50 km, 10⁻³ at 300 km.
//   * ecef: the Earth as it is, seen from the centre: (x, y, z) = (E, N, U)·(P(h) − C), a rigid motion
//     of geocentric coordinates, so every distance is true and the ground curves away from the plane
//     (by d²/2R: 196 m at 50 km), for continental extents.
// - Any raster, reprojected into a projected CRS in metres that the user names (`--frame EPSG:N`): a
//   sample's position is PROJ's transformation of its CRS position into that CRS, moved so that the
//   raster's centre sample (rounded to the metre) is at x = y = 0; z its height. GEOR holds that CRS and
//   origin, as for a projected raster's own plane, so the model sits with scans and other terrains
//   built in that CRS; the grid is no longer regular in the plane (as in enu).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "preprocess/elevation_raster.h"

namespace strata {

enum class TerrainFrameKind : uint32_t { projected = 0, enu = 1, ecef = 2, reprojected = 3 };

// An ellipsoid and a tangent point on it: the enu and ecef frames above, both ways.
class TangentPlane {
public:
    TangentPlane() = default;
    // a in metres, 1/f (0 for a sphere), the tangent point's longitude and latitude in degrees.
    TangentPlane(double semi_major, double inverse_flattening, double longitude, double latitude);

    // Geocentric coordinates of (longitude, latitude in degrees, height in metres).
    std::array<double, 3> geocentric(double longitude, double latitude, double height) const;
    // The model position of a point: enu (flat) or ecef (curved) as above.
    std::array<double, 3> local(double longitude, double latitude, double height, TerrainFrameKind kind) const;
    // Back: the longitude, latitude and height of a model position. enu: the ellipsoid point straight
    // below (x, y) along the plane's normal, with height z; ecef: the point itself.
    std::array<double, 3> geodetic(const std::array<double, 3>& position, TerrainFrameKind kind) const;

private:
    double a_ = 0, e2_ = 0;
    std::array<double, 3> center_{}, east_{}, north_{}, up_{};
};

class TerrainFrame {
public:
    // The frame for the raster's CRS: a projected CRS's own plane, or for a geographic CRS, `geographic`
    // (enu or ecef); or, when `crs` names one (EPSG:N, WKT, a PROJ string), the raster reprojected into
    // that CRS. Throws InputError for a projected CRS not in metres, and for a `crs` PROJ cannot read,
    // not projected, or with no way to it from the raster's.
    static TerrainFrame for_raster(const RasterInfo& info, TerrainFrameKind geographic = TerrainFrameKind::enu, const std::string& crs = {});

    // Throws InputError ("--frame CRS: ...") unless `crs` is a projected CRS in metres that PROJ reads.
    static void check_crs(const std::string& crs);

    TerrainFrameKind kind() const { return kind_; }
    // Reprojected: the CRS the raster is reprojected into, as given.
    const std::string& crs() const { return crs_; }
    // Projected, reprojected: the CRS position of model x = y = 0 (z: 0). enu, ecef: the centre's
    // longitude and latitude (degrees) and height (0).
    const std::array<double, 3>& geo_origin() const { return geo_origin_; }
    // The model position of the sample at (column, row) with height h (metres). Safe to call from
    // several threads. Reprojected: throws InputError for a sample PROJ cannot map.
    std::array<double, 3> position(uint64_t column, uint64_t row, double height) const;
    // Metres between neighbouring samples along a row and along a column, at the raster's centre.
    std::array<double, 2> spacing() const { return spacing_; }

private:
    class Reprojection;
    TerrainFrameKind kind_ = TerrainFrameKind::projected;
    RasterInfo info_;
    std::string crs_;
    std::array<double, 3> geo_origin_{};
    std::array<double, 2> spacing_{};
    TangentPlane tangent_;                               // enu, ecef
    std::shared_ptr<const Reprojection> reprojection_;  // reprojected
};

}  // namespace strata
