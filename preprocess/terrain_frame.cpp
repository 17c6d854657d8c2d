#include "preprocess/terrain_frame.h"

#include <cmath>
#include <stdexcept>
#include <numbers>

#include "preprocess/mesh.h"

namespace strata {
namespace {

constexpr double kDegree = std::numbers::pi / 180;

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

}  // namespace

TangentPlane::TangentPlane(double semi_major, double inverse_flattening, double longitude, double latitude) : a_(semi_major) {
    const double flattening = inverse_flattening > 0 ? 1 / inverse_flattening : 0;
    e2_ = flattening * (2 - flattening);
    const double l = longitude * kDegree, p = latitude * kDegree;
    center_ = geocentric(longitude, latitude, 0);
    east_ = {-std::sin(l), std::cos(l), 0};
    north_ = {-std::sin(p) * std::cos(l), -std::sin(p) * std::sin(l), std::cos(p)};
    up_ = {std::cos(p) * std::cos(l), std::cos(p) * std::sin(l), std::sin(p)};
}

std::array<double, 3> TangentPlane::geocentric(double longitude, double latitude, double height) const {
    const double l = longitude * kDegree, p = latitude * kDegree;
    const double n = a_ / std::sqrt(1 - e2_ * std::sin(p) * std::sin(p));
    return {(n + height) * std::cos(p) * std::cos(l), (n + height) * std::cos(p) * std::sin(l), (n * (1 - e2_) + height) * std::sin(p)};
}

std::array<double, 3> TangentPlane::local(double longitude, double latitude, double height, TerrainFrameKind kind) const {
    const bool flat = kind == TerrainFrameKind::enu;
    const std::array<double, 3> p = geocentric(longitude, latitude, flat ? 0 : height);
    const double d[3] = {p[0] - center_[0], p[1] - center_[1], p[2] - center_[2]};
    auto dot = [&](const std::array<double, 3>& axis) { return axis[0] * d[0] + axis[1] * d[1] + axis[2] * d[2]; };
    return {dot(east_), dot(north_), flat ? height : dot(up_)};
}

std::array<double, 3> TangentPlane::geodetic(const std::array<double, 3>& position, TerrainFrameKind kind) const {
    const bool flat = kind == TerrainFrameKind::enu;
    const double z = flat ? 0 : position[2];
    std::array<double, 3> p;
    for (size_t a = 0; a < 3; ++a) p[a] = center_[a] + position[0] * east_[a] + position[1] * north_[a] + z * up_[a];
    if (flat) {
        // The ellipsoid (X² + Y²)/a² + Z²/b² = 1 meets the line p + t·up where the quadratic in t has its
        // root nearer the plane (the ground below or above the plane's point, not the far side).
        const double b2 = a_ * a_ * (1 - e2_);
        const double qa = (up_[0] * up_[0] + up_[1] * up_[1]) / (a_ * a_) + up_[2] * up_[2] / b2;
        const double qb = 2 * ((p[0] * up_[0] + p[1] * up_[1]) / (a_ * a_) + p[2] * up_[2] / b2);
        const double qc = (p[0] * p[0] + p[1] * p[1]) / (a_ * a_) + p[2] * p[2] / b2 - 1;
        const double disc = qb * qb - 4 * qa * qc;
        if (!(disc >= 0)) return {NAN, NAN, NAN};  // beyond the ellipsoid's outline, seen along the normal
        // The root of smaller magnitude, in the form that does not cancel.
        const double q = -0.5 * (qb + std::copysign(std::sqrt(disc), qb));
        const double t = q != 0 ? qc / q : 0;
        for (size_t a = 0; a < 3; ++a) p[a] += t * up_[a];
    }
    // Geocentric to geodetic by fixed-point iteration on the latitude (converges to 1e-12 rad in a few
    // steps near the ground).
    const double r = std::hypot(p[0], p[1]);
    double latitude = std::atan2(p[2], r * (1 - e2_)), height = 0;
    for (int i = 0; i < 8; ++i) {
        const double n = a_ / std::sqrt(1 - e2_ * std::sin(latitude) * std::sin(latitude));
        height = std::abs(std::cos(latitude)) > 1e-9 ? r / std::cos(latitude) - n : std::abs(p[2]) - n * (1 - e2_);
        latitude = std::atan2(p[2], r * (1 - e2_ * n / (n + height)));
    }
    return {std::atan2(p[1], p[0]) / kDegree, latitude / kDegree, flat ? position[2] : height};
}

TerrainFrame TerrainFrame::for_raster(const RasterInfo& info, TerrainFrameKind geographic) {
    TerrainFrame f;
    f.info_ = info;
    const std::array<double, 6>& g = info.geotransform;
    if (!info.geographic) {
        if (std::abs(info.linear_unit - 1) > 1e-12)
            throw InputError(info.name + ": a projected CRS in units of " + std::to_string(info.linear_unit) +
                             " m; Strata builds terrains in metre-based CRSs (reproject it with gdalwarp)");
        const double south_row = g[5] > 0 ? 0.5 : double(info.height) - 0.5;
        f.geo_origin_ = {g[0] + 0.5 * g[1], g[3] + south_row * g[5], 0};
        f.spacing_ = {g[1], std::abs(g[5])};
        return f;
    }
    if (!(info.semi_major > 0)) throw InputError(info.name + ": a geographic CRS without an ellipsoid");
    if (geographic == TerrainFrameKind::projected) throw std::invalid_argument("TerrainFrame: a geographic raster's frame is enu or ecef");
    f.kind_ = geographic;
    const double column = double(info.width - 1) / 2, row = double(info.height - 1) / 2;
    const double longitude = g[0] + (column + 0.5) * g[1], latitude = g[3] + (row + 0.5) * g[5];
    if (!(std::abs(latitude) < 90)) throw InputError(info.name + ": its centre is not a latitude (" + std::to_string(latitude) + "°)");
    f.geo_origin_ = {longitude, latitude, 0};
    f.tangent_ = TangentPlane(info.semi_major, info.inverse_flattening, longitude, latitude);
    const uint64_t c = (info.width - 1) / 2, r = (info.height - 1) / 2;
    f.spacing_ = {distance(f.position(c, r, 0), f.position(c + 1, r, 0)), distance(f.position(c, r, 0), f.position(c, r + 1, 0))};
    return f;
}

std::array<double, 3> TerrainFrame::position(uint64_t column, uint64_t row, double height) const {
    if (kind_ == TerrainFrameKind::projected) {
        const double y = double(info_.geotransform[5] > 0 ? row : info_.height - 1 - row) * spacing_[1];
        return {double(column) * spacing_[0], y, height};
    }
    const std::array<double, 6>& g = info_.geotransform;
    return tangent_.local(g[0] + (double(column) + 0.5) * g[1], g[3] + (double(row) + 0.5) * g[5], height, kind_);
}

}  // namespace strata
