#include "preprocess/terrain_bounds.h"

#include <algorithm>
#include <cmath>

namespace strata::terrain {
namespace {

using Point2 = std::array<double, 2>;
using Point3 = std::array<double, 3>;

double distance(const double* a, const double* b) {
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

double cross(const Point2& o, const Point2& a, const Point2& b) {
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

// A triangle of one level: its corners in the parameter plane and in model space.
struct Triangle {
    Point2 param[3];
    const double* at[3];
    build::CubeKey cube;

    // The model point at a parameter point (barycentric in the plane; the map is linear over the triangle).
    Point3 point(const Point2& p) const {
        const double area = cross(param[0], param[1], param[2]);
        const double b1 = cross(param[0], p, param[2]) / area, b2 = cross(param[0], param[1], p) / area, b0 = 1 - b1 - b2;
        return {b0 * at[0][0] + b1 * at[1][0] + b2 * at[2][0], b0 * at[0][1] + b1 * at[1][1] + b2 * at[2][1],
                b0 * at[0][2] + b1 * at[1][2] + b2 * at[2][2]};
    }
};

Triangle triangle(const TerrainLevel& level, size_t column, size_t row, int t) {
    Triangle tri;
    tri.cube = level.cube[2 * level.cell(column, row) + t];
    const std::array<uint64_t, 3> v = level.corners(column, row, t);
    for (int i = 0; i < 3; ++i) {
        tri.param[i] = {double(level.columns[v[i] % level.width()]), double(level.rows[v[i] / level.width()])};
        tri.at[i] = level.at(v[i]);
    }
    return tri;
}

// The part of the plane two triangles share (Sutherland–Hodgman: `a` clipped by each side of `b`).
std::vector<Point2> overlap(const Triangle& a, const Triangle& b) {
    std::vector<Point2> polygon(a.param, a.param + 3), next;
    const double orientation = cross(b.param[0], b.param[1], b.param[2]) > 0 ? 1 : -1;
    for (int e = 0; e < 3 && !polygon.empty(); ++e) {
        const Point2 &p = b.param[e], &q = b.param[(e + 1) % 3];
        next.clear();
        for (size_t i = 0; i < polygon.size(); ++i) {
            const Point2 &s = polygon[i], &t = polygon[(i + 1) % polygon.size()];
            const double ds = orientation * cross(p, q, s), dt = orientation * cross(p, q, t);
            if (ds >= 0) next.push_back(s);
            if ((ds >= 0) != (dt >= 0)) {
                const double k = ds / (ds - dt);
                next.push_back({s[0] + k * (t[0] - s[0]), s[1] + k * (t[1] - s[1])});
            }
        }
        polygon.swap(next);
    }
    return polygon;
}

// The largest gap between two triangles over the part of the plane they share (−1: none).
double gap(const Triangle& finer, const Triangle& coarse) {
    double worst = -1;
    for (const Point2& p : overlap(finer, coarse)) {
        const Point3 a = finer.point(p), b = coarse.point(p);
        worst = std::max(worst, distance(a.data(), b.data()));
    }
    return worst;
}

void raise(CubeDistances& distances, build::CubeKey cube, double value) {
    double& d = distances[cube];
    d = std::max(d, value);
}

double forward_of(const CubeDistances& forward, build::CubeKey cube) {
    auto it = forward.find(cube);
    return it == forward.end() ? 0.0 : it->second;
}

class StepBounder {
public:
    StepBounder(const TerrainLevel& finer, const TerrainLevel& coarse, const CubeDistances& finer_forward, double far)
        : finer_(finer), coarse_(coarse), finer_forward_(finer_forward), far_(far) {}

    StepBound run() {
        for (size_t r = 0; r + 1 < coarse_.height(); ++r)
            for (size_t c = 0; c + 1 < coarse_.width(); ++c) cell(c, r);
        return std::move(out_);
    }

private:
    void cell(size_t c, size_t r) {
        const size_t c0 = finer_position(c, coarse_.width(), finer_.width()), c1 = finer_position(c + 1, coarse_.width(), finer_.width());
        const size_t r0 = finer_position(r, coarse_.height(), finer_.height()), r1 = finer_position(r + 1, coarse_.height(), finer_.height());
        std::vector<Triangle> fine;
        for (size_t fr = r0; fr < r1; ++fr)
            for (size_t fc = c0; fc < c1; ++fc)
                for (int t = 0; t < 2; ++t)
                    if (finer_.cube[2 * finer_.cell(fc, fr) + t] != kNoTriangle) fine.push_back(triangle(finer_, fc, fr, t));
        if (fine.empty()) return;
        const bool all_fine = fine.size() == 2 * (c1 - c0) * (r1 - r0);
        bool all_coarse = true;
        for (int t = 0; t < 2; ++t) {
            if (coarse_.cube[2 * coarse_.cell(c, r) + t] == kNoTriangle) {
                all_coarse = false;
                continue;
            }
            const Triangle big = triangle(coarse_, c, r, t);
            for (const Triangle& small : fine)
                if (const double d = gap(small, big); d >= 0) {
                    raise(out_.forward, big.cube, d + forward_of(finer_forward_, small.cube));
                    raise(out_.finer_coverage, small.cube, d);
                }
            // Part of it over a hole: within the corners' travel of the finer triangle that maps onto it.
            if (!all_fine) {
                const Triangle preimage = triangle(finer_, c1 - 1, r1 - 1, t);
                raise(out_.forward, big.cube, travel(preimage, big) + forward_of(finer_forward_, preimage.cube));
            }
        }
        if (!all_coarse)
            for (const Triangle& small : fine) raise(out_.finer_coverage, small.cube, collapse_bound(small));
    }

    // max |V_i − u_i| over corresponding corners.
    static double travel(const Triangle& finer, const Triangle& coarse) {
        double worst = 0;
        for (int i = 0; i < 3; ++i) worst = std::max(worst, distance(finer.at[i], coarse.at[i]));
        return worst;
    }

    // How far a finer triangle's points are from the coarse surface, by where P takes its corners.
    double collapse_bound(const Triangle& small) const {
        std::array<uint64_t, 3> image;
        double travel = 0;
        for (int i = 0; i < 3; ++i) {
            image[size_t(i)] = parent_vertex(small.param[i]);
            travel = std::max(travel, distance(small.at[i], coarse_.at(image[size_t(i)])));
        }
        if (on_coarse_surface(image)) return travel;
        return nearest_used(small, image[0]);
    }

    uint64_t parent_vertex(const Point2& param) const {
        const size_t fc = size_t(std::lower_bound(finer_.columns.begin(), finer_.columns.end(), uint64_t(param[0])) - finer_.columns.begin());
        const size_t fr = size_t(std::lower_bound(finer_.rows.begin(), finer_.rows.end(), uint64_t(param[1])) - finer_.rows.begin());
        return coarse_.vertex(parent_position(fc, finer_.width()), parent_position(fr, finer_.height()));
    }

    // Whether the corners (distinct or not) all belong to one coarse triangle.
    bool on_coarse_surface(const std::array<uint64_t, 3>& image) const {
        const size_t c = image[0] % coarse_.width(), r = image[0] / coarse_.width();
        for (size_t cr = r ? r - 1 : 0; cr <= r && cr + 1 < coarse_.height(); ++cr)
            for (size_t cc = c ? c - 1 : 0; cc <= c && cc + 1 < coarse_.width(); ++cc)
                for (int t = 0; t < 2; ++t) {
                    if (coarse_.cube[2 * coarse_.cell(cc, cr) + t] == kNoTriangle) continue;
                    const std::array<uint64_t, 3> corners = coarse_.corners(cc, cr, t);
                    bool all = true;
                    for (uint64_t v : image) all = all && std::find(corners.begin(), corners.end(), v) != corners.end();
                    if (all) return true;
                }
        return false;
    }

    // A fragment the coarse level dropped: its distance to the nearest vertex a coarse triangle uses,
    // searched in rings around where it collapsed; the model's diagonal when none is near.
    double nearest_used(const Triangle& small, uint64_t around) const {
        constexpr int64_t kRings = 8;
        const int64_t c = int64_t(around % coarse_.width()), r = int64_t(around / coarse_.width());
        for (int64_t ring = 1; ring <= kRings; ++ring) {
            double best = far_;
            for (int64_t dr = -ring; dr <= ring; ++dr)
                for (int64_t dc = -ring; dc <= ring; ++dc) {
                    if (std::max(std::abs(dr), std::abs(dc)) != ring) continue;
                    const int64_t vc = c + dc, vr = r + dr;
                    if (vc < 0 || vr < 0 || vc >= int64_t(coarse_.width()) || vr >= int64_t(coarse_.height())) continue;
                    const uint64_t v = coarse_.vertex(size_t(vc), size_t(vr));
                    if (!(coarse_.flags[v] & kUsed)) continue;
                    double reach = 0;
                    for (int i = 0; i < 3; ++i) reach = std::max(reach, distance(small.at[i], coarse_.at(v)));
                    best = std::min(best, reach);
                }
            if (best < far_) return best;
        }
        return far_;
    }

    const TerrainLevel &finer_, &coarse_;
    const CubeDistances& finer_forward_;
    const double far_;
    StepBound out_;
};

}  // namespace

StepBound bound_step(const TerrainLevel& finer, const TerrainLevel& coarse, const CubeDistances& finer_forward, double far) {
    return StepBounder(finer, coarse, finer_forward, far).run();
}

}  // namespace strata::terrain
