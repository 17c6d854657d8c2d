#include "preprocess/terrain_frame.h"

#include <proj.h>

#include <cmath>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "preprocess/mesh.h"

namespace strata {
namespace {

constexpr double kDegree = std::numbers::pi / 180;

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

}  // namespace

// PROJ's transformation from the raster's CRS into the frame's, easting (longitude) first both ways.
// PROJ's objects are not thread-safe: a thread takes one of its own (in a context of its own) from
// a pool for each point.
class TerrainFrame::Reprojection {
public:
    Reprojection(const RasterInfo& info, const std::string& crs) : from_(info.crs_wkt), to_(crs), name_(info.name) {
        check_frame_crs(crs);
        free_.push_back(make());
    }
    // Throws InputError unless `crs` is a projected CRS in metres that PROJ reads.
    static void check_frame_crs(const std::string& crs) {
        PJ_CONTEXT* context = proj_context_create();
        proj_log_level(context, PJ_LOG_NONE);
        PJ* target = proj_create(context, crs.c_str());
        std::string problem;
        if (!target) {
            problem = "not a CRS PROJ knows";
        } else if (proj_get_type(target) != PJ_TYPE_PROJECTED_CRS) {
            problem = "not a projected CRS (a terrain's frame is a plane in metres)";
        } else {
            PJ* cs = proj_crs_get_coordinate_system(context, target);
            double to_metres = 0;
            if (!cs || !proj_cs_get_axis_info(context, cs, 0, nullptr, nullptr, nullptr, &to_metres, nullptr, nullptr, nullptr) || to_metres != 1)
                problem = "a projected CRS not in metres";
            proj_destroy(cs);
        }
        proj_destroy(target);
        proj_context_destroy(context);
        if (!problem.empty()) throw InputError("--frame " + crs + ": " + problem);
    }
    ~Reprojection() {
        for (Handle& h : free_) proj_destroy(h.pj), proj_context_destroy(h.context);
    }
    Reprojection(const Reprojection&) = delete;
    Reprojection& operator=(const Reprojection&) = delete;

    // The frame CRS's easting and northing of a raster CRS position.
    std::array<double, 2> operator()(double x, double y) const {
        Handle h;
        {
            std::lock_guard lock(mutex_);
            if (!free_.empty()) h = free_.back(), free_.pop_back();
        }
        if (!h.pj) h = make();
        const PJ_COORD out = proj_trans(h.pj, PJ_FWD, proj_coord(x, y, 0, 0));
        {
            std::lock_guard lock(mutex_);
            free_.push_back(h);
        }
        if (!std::isfinite(out.xy.x) || !std::isfinite(out.xy.y) || out.xy.x == HUGE_VAL)
            throw InputError(name_ + ": (" + std::to_string(x) + ", " + std::to_string(y) + ") lies outside what PROJ maps into " + to_);
        return {out.xy.x, out.xy.y};
    }

private:
    struct Handle {
        PJ_CONTEXT* context = nullptr;
        PJ* pj = nullptr;
    };
    Handle make() const {
        Handle h{proj_context_create(), nullptr};
        proj_log_level(h.context, PJ_LOG_NONE);
        PJ* raw = proj_create_crs_to_crs(h.context, from_.c_str(), to_.c_str(), nullptr);
        h.pj = raw ? proj_normalize_for_visualization(h.context, raw) : nullptr;
        proj_destroy(raw);
        if (!h.pj) {
            proj_context_destroy(h.context);
            throw InputError("--frame " + to_ + ": PROJ finds no way to it from " + name_ + "'s CRS");
        }
        return h;
    }
    const std::string from_, to_, name_;
    mutable std::mutex mutex_;
    mutable std::vector<Handle> free_;
};

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

void TerrainFrame::check_crs(const std::string& crs) { Reprojection::check_frame_crs(crs); }

TerrainFrame TerrainFrame::for_raster(const RasterInfo& info, TerrainFrameKind geographic, const std::string& crs) {
    TerrainFrame f;
    f.info_ = info;
    const std::array<double, 6>& g = info.geotransform;
    if (!crs.empty()) {
        f.kind_ = TerrainFrameKind::reprojected;
        f.crs_ = crs;
        f.reprojection_ = std::make_shared<const Reprojection>(info, crs);
        const uint64_t c = (info.width - 1) / 2, r = (info.height - 1) / 2;
        const std::array<double, 2> centre = (*f.reprojection_)(g[0] + (double(c) + 0.5) * g[1], g[3] + (double(r) + 0.5) * g[5]);
        f.geo_origin_ = {std::round(centre[0]), std::round(centre[1]), 0};
        f.spacing_ = {distance(f.position(c, r, 0), f.position(c + 1, r, 0)), distance(f.position(c, r, 0), f.position(c, r + 1, 0))};
        return f;
    }
    if (!info.geographic) {
        if (std::abs(info.linear_unit - 1) > 1e-12)
            throw InputError(info.name + ": a projected CRS in units of " + std::to_string(info.linear_unit) +
                             " m; Strata builds terrains in metre-based CRSs (name one: --frame EPSG:N)");
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
    const double x = g[0] + (double(column) + 0.5) * g[1], y = g[3] + (double(row) + 0.5) * g[5];
    if (kind_ == TerrainFrameKind::reprojected) {
        const std::array<double, 2> p = (*reprojection_)(x, y);
        return {p[0] - geo_origin_[0], p[1] - geo_origin_[1], height};
    }
    return tangent_.local(x, y, height, kind_);
}

}  // namespace strata
