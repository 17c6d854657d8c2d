#include "preprocess/georeference.h"

#include <proj.h>

#include <cmath>
#include <stdexcept>

namespace strata {
namespace {

// How far east of the raster's first sample a longitude lies, in degrees. Longitudes come back in
// (−180°, 180°]; a raster may start anywhere (0 … 360° grids) and span more than half the globe: east
// of the first sample by less than a turn.
double longitude_east_of_first(double longitude, const TerrainGrid& t) {
    double east = std::remainder(longitude - t.first_sample[0], 360.0);
    if (east < -0.5 * t.spacing[0] && east + 360 <= double(t.columns - 1) * t.spacing[0] + 0.5 * t.spacing[0]) east += 360;
    return east;
}

}  // namespace

struct Georeference::Proj {
    PJ_CONTEXT* context = proj_context_create();
    PJ* source = nullptr;                   // the model's CRS
    std::map<std::string, PJ*> transforms;  // by target CRS ("" for the model CRS's geographic one)

    ~Proj() {
        for (auto& [crs, pj] : transforms) proj_destroy(pj);
        proj_destroy(source);
        proj_context_destroy(context);
    }
    std::string last_error() const { return proj_context_errno_string(context, proj_context_errno(context)); }
};

std::string vertical_datum(const std::string& crs) {
    PJ_CONTEXT* context = proj_context_create();
    proj_log_level(context, PJ_LOG_NONE);
    PJ* pj = proj_create(context, crs.c_str());
    std::string name;
    const bool read = pj != nullptr;
    if (read && proj_get_type(pj) == PJ_TYPE_COMPOUND_CRS)
        if (PJ* vertical = proj_crs_get_sub_crs(context, pj, 1)) {
            if (const char* text = proj_get_name(vertical)) name = text;
            proj_destroy(vertical);
        }
    if (read && proj_get_type(pj) == PJ_TYPE_VERTICAL_CRS)
        if (const char* text = proj_get_name(pj)) name = text;
    proj_destroy(pj);
    proj_context_destroy(context);
    if (!read) throw std::runtime_error("PROJ cannot read the CRS '" + crs + "'");
    return name;
}

Georeference::Georeference(const HlodHeader& header, std::string name)
    : name_(std::move(name)), crs_(header.crs), terrain_(header.terrain), proj_(std::make_unique<Proj>()) {
    if (crs_.empty()) throw std::runtime_error(name_ + ": the model has no georeference (it was built from a file without a CRS)");
    std::copy(std::begin(header.geo_origin), std::end(header.geo_origin), geo_origin_.begin());
    if (terrain_ && terrain_->tangent_frame()) tangent_ = TangentPlane(terrain_->semi_major, terrain_->inverse_flattening, geo_origin_[0], geo_origin_[1]);
    proj_log_level(proj_->context, PJ_LOG_NONE);
}

Georeference::~Georeference() = default;

std::array<double, 3> Georeference::model_to_crs(const std::array<double, 3>& model) const {
    if (terrain_ && terrain_->tangent_frame()) return tangent_.geodetic(model, TerrainFrameKind(terrain_->frame));
    return {geo_origin_[0] + model[0], geo_origin_[1] + model[1], geo_origin_[2] + model[2]};
}

std::array<double, 3> Georeference::crs_to_model(const std::array<double, 3>& crs) const {
    if (terrain_ && terrain_->tangent_frame()) return tangent_.local(crs[0], crs[1], crs[2], TerrainFrameKind(terrain_->frame));
    return {crs[0] - geo_origin_[0], crs[1] - geo_origin_[1], crs[2] - geo_origin_[2]};
}

void* Georeference::transformation(const std::string& crs) const {
    Proj& p = *proj_;
    if (auto found = p.transforms.find(crs); found != p.transforms.end()) return found->second;
    if (!p.source) {
        p.source = proj_create(p.context, crs_.c_str());
        if (!p.source) throw std::runtime_error(name_ + ": PROJ cannot read the model's CRS (" + p.last_error() + ")");
    }
    PJ* target = crs.empty() ? proj_crs_get_geodetic_crs(p.context, p.source) : proj_create(p.context, crs.c_str());
    if (!target) throw std::runtime_error(crs.empty() ? name_ + ": the model's CRS has no geographic CRS" : "PROJ cannot read the CRS '" + crs + "' (" + p.last_error() + ")");
    PJ* raw = proj_create_crs_to_crs_from_pj(p.context, p.source, target, nullptr, nullptr);
    proj_destroy(target);
    PJ* normalised = raw ? proj_normalize_for_visualization(p.context, raw) : nullptr;
    proj_destroy(raw);
    if (!normalised) throw std::runtime_error("PROJ finds no way from " + name_ + "'s CRS to '" + (crs.empty() ? "its geographic CRS" : crs) + "' (" + p.last_error() + ")");
    p.transforms.emplace(crs, normalised);
    return normalised;
}

std::array<double, 3> Georeference::transform(const std::array<double, 3>& point, const std::string& crs, bool forward) const {
    std::lock_guard lock(mutex_);
    PJ* pj = static_cast<PJ*>(transformation(crs));
    proj_errno_reset(pj);
    const PJ_COORD out = proj_trans(pj, forward ? PJ_FWD : PJ_INV, proj_coord(point[0], point[1], point[2], 0));
    if (!std::isfinite(out.xyz.x) || !std::isfinite(out.xyz.y) || out.xyz.x == HUGE_VAL)
        throw std::runtime_error("(" + std::to_string(point[0]) + ", " + std::to_string(point[1]) + ") lies outside what PROJ maps between " + name_ +
                                 "'s CRS and " + (crs.empty() ? "its geographic CRS" : "'" + crs + "'"));
    return {out.xyz.x, out.xyz.y, point[2]};
}

std::array<double, 3> Georeference::to_geo(const std::array<double, 3>& model, const std::string& crs) const {
    for (double v : model)
        if (!std::isfinite(v)) throw std::runtime_error("a position that is not finite");
    const std::array<double, 3> c = model_to_crs(model);
    if (!std::isfinite(c[0]) || !std::isfinite(c[1])) throw std::runtime_error("a position beyond the ellipsoid's outline in " + name_ + "'s tangent plane");
    return transform(c, crs, true);
}

std::array<double, 3> Georeference::to_local(const std::array<double, 3>& geo, const std::string& crs) const {
    for (double v : geo)
        if (!std::isfinite(v)) throw std::runtime_error("coordinates that are not finite");
    return crs_to_model(transform(geo, crs, false));
}

std::optional<std::array<double, 2>> Georeference::raster_position(double x, double y, double height) const {
    if (!terrain_) return std::nullopt;
    const TerrainGrid& t = *terrain_;
    double east = geo_origin_[0] + x - t.first_sample[0], cy = geo_origin_[1] + y;
    if (t.frame == uint32_t(TerrainFrameKind::reprojected)) {
        // Back into the raster's CRS, through PROJ; a point PROJ cannot map lies off the raster.
        std::array<double, 3> at;
        try {
            at = transform({geo_origin_[0] + x, geo_origin_[1] + y, height}, t.raster_crs, true);
        } catch (const std::runtime_error&) {
            return std::nullopt;
        }
        east = t.raster_geographic ? longitude_east_of_first(at[0], t) : at[0] - t.first_sample[0];
        cy = at[1];
    } else if (t.tangent_frame()) {
        // The ellipsoid point with these x, y; in ecef, moved until the point `height` above it has them
        // (each step shifts by the tilt of the normal: a few steps reach a micrometre).
        std::array<double, 3> g = tangent_.geodetic({x, y, 0}, TerrainFrameKind::enu);
        for (int i = 0; t.frame == uint32_t(TerrainFrameKind::ecef) && height != 0 && i < 6; ++i) {
            const std::array<double, 3> at_height = tangent_.local(g[0], g[1], height, TerrainFrameKind::ecef);
            const std::array<double, 3> at_ground = tangent_.local(g[0], g[1], 0, TerrainFrameKind::enu);
            g = tangent_.geodetic({at_ground[0] + x - at_height[0], at_ground[1] + y - at_height[1], 0}, TerrainFrameKind::enu);
        }
        east = longitude_east_of_first(g[0], t);
        cy = g[1];
    }
    const double column = east / t.spacing[0];
    const double row = (t.rows_run_north ? cy - t.first_sample[1] : t.first_sample[1] - cy) / t.spacing[1];
    return std::array{column, row};
}

std::optional<std::array<double, 3>> Georeference::sample_position(double column, double row, double height) const {
    if (!terrain_) return std::nullopt;
    const TerrainGrid& t = *terrain_;
    const double x = t.first_sample[0] + column * t.spacing[0];
    const double y = t.rows_run_north ? t.first_sample[1] + row * t.spacing[1] : t.first_sample[1] - row * t.spacing[1];
    if (t.frame == uint32_t(TerrainFrameKind::reprojected)) return crs_to_model(transform({x, y, height}, t.raster_crs, false));
    return crs_to_model({x, y, height});
}

}  // namespace strata
