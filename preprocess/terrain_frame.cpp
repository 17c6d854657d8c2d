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
    f.a_ = info.semi_major;
    const double flattening = info.inverse_flattening > 0 ? 1 / info.inverse_flattening : 0;
    f.e2_ = flattening * (2 - flattening);
    const double column = double(info.width - 1) / 2, row = double(info.height - 1) / 2;
    const double longitude = g[0] + (column + 0.5) * g[1], latitude = g[3] + (row + 0.5) * g[5];
    if (!(std::abs(latitude) < 90)) throw InputError(info.name + ": its centre is not a latitude (" + std::to_string(latitude) + "°)");
    f.geo_origin_ = {longitude, latitude, 0};
    const double l = longitude * kDegree, p = latitude * kDegree;
    f.center_ = f.geocentric(longitude, latitude, 0);
    f.east_ = {-std::sin(l), std::cos(l), 0};
    f.north_ = {-std::sin(p) * std::cos(l), -std::sin(p) * std::sin(l), std::cos(p)};
    f.up_ = {std::cos(p) * std::cos(l), std::cos(p) * std::sin(l), std::sin(p)};
    const uint64_t c = (info.width - 1) / 2, r = (info.height - 1) / 2;
    f.spacing_ = {distance(f.position(c, r, 0), f.position(c + 1, r, 0)), distance(f.position(c, r, 0), f.position(c, r + 1, 0))};
    return f;
}

std::array<double, 3> TerrainFrame::geocentric(double longitude, double latitude, double height) const {
    const double l = longitude * kDegree, p = latitude * kDegree;
    const double n = a_ / std::sqrt(1 - e2_ * std::sin(p) * std::sin(p));
    return {(n + height) * std::cos(p) * std::cos(l), (n + height) * std::cos(p) * std::sin(l), (n * (1 - e2_) + height) * std::sin(p)};
}

std::array<double, 3> TerrainFrame::position(uint64_t column, uint64_t row, double height) const {
    if (kind_ == TerrainFrameKind::projected) {
        const double y = double(info_.geotransform[5] > 0 ? row : info_.height - 1 - row) * spacing_[1];
        return {double(column) * spacing_[0], y, height};
    }
    const std::array<double, 6>& g = info_.geotransform;
    const bool flat = kind_ == TerrainFrameKind::enu;
    const std::array<double, 3> p = geocentric(g[0] + (double(column) + 0.5) * g[1], g[3] + (double(row) + 0.5) * g[5], flat ? 0 : height);
    const double d[3] = {p[0] - center_[0], p[1] - center_[1], p[2] - center_[2]};
    auto dot = [&](const std::array<double, 3>& axis) { return axis[0] * d[0] + axis[1] * d[1] + axis[2] * d[2]; };
    return {dot(east_), dot(north_), flat ? height : dot(up_)};
}

}  // namespace strata
