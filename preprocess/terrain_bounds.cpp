#include "preprocess/terrain_bounds.h"

#include <algorithm>
#include <cmath>
#include <span>

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

// A cube's distance raised to at least a value; the last cube's entry kept at hand, since neighbouring
// cells nearly always belong to one cube.
class Raise {
public:
    explicit Raise(CubeDistances& distances) : distances_(distances) {}
    void operator()(build::CubeKey cube, double value) {
        if (cube != cube_) entry_ = &distances_[cube], cube_ = cube;  // entries keep their place when the map grows
        *entry_ = std::max(*entry_, value);
    }

private:
    CubeDistances& distances_;
    build::CubeKey cube_ = kNoTriangle;
    double* entry_ = nullptr;
};

// A finer cube's F (0 when it has none), the last one kept at hand.
class Forward {
public:
    explicit Forward(const CubeDistances& forward) : forward_(forward) {}
    double operator()(build::CubeKey cube) {
        if (cube != cube_) {
            auto it = forward_.find(cube);
            value_ = it == forward_.end() ? 0.0 : it->second, cube_ = cube;
        }
        return value_;
    }

private:
    const CubeDistances& forward_;
    build::CubeKey cube_ = kNoTriangle;
    double value_ = 0;
};

class StepBounder {
public:
    StepBounder(const TerrainLevel& finer, const TerrainLevel& coarse, const CubeDistances& finer_forward, double far)
        : finer_(finer), coarse_(coarse), far_(far), finer_forward_(finer_forward), raise_forward_(out_.forward),
          raise_coverage_(out_.finer_coverage) {}

    StepBound run() {
        for (size_t r = 0; r + 1 < coarse_.height(); ++r)
            for (size_t c = 0; c + 1 < coarse_.width(); ++c) cell(c, r);
        return std::move(out_);
    }

private:
    void cell(size_t c, size_t r) {
        const size_t c0 = finer_.columns.finer(c, coarse_.columns), c1 = finer_.columns.finer(c + 1, coarse_.columns);
        const size_t r0 = finer_.rows.finer(r, coarse_.rows), r1 = finer_.rows.finer(r + 1, coarse_.rows);
        Triangle fine[8];
        size_t count = 0;
        for (size_t fr = r0; fr < r1; ++fr)
            for (size_t fc = c0; fc < c1; ++fc)
                for (int t = 0; t < 2; ++t)
                    if (finer_.cube[2 * finer_.cell(fc, fr) + t] != kNoTriangle) fine[count++] = triangle(finer_, fc, fr, t);
        if (count == 0) return;
        const bool all_fine = count == 2 * (c1 - c0) * (r1 - r0);
        if (all_fine && nested(c, r, c0, r0, c1, r1)) return whole_cell(c, r, c0, r0, {fine, count});
        bool all_coarse = true;
        for (int t = 0; t < 2; ++t) {
            if (coarse_.cube[2 * coarse_.cell(c, r) + t] == kNoTriangle) {
                all_coarse = false;
                continue;
            }
            const Triangle big = triangle(coarse_, c, r, t);
            for (const Triangle& small : std::span(fine, count))
                if (const double d = gap(small, big); d >= 0) {
                    raise_forward_(big.cube, d + finer_forward_(small.cube));
                    raise_coverage_(small.cube, d);
                }
            // Part of it over a hole: within the corners' travel of the finer triangle that maps onto it.
            if (!all_fine) {
                const Triangle preimage = triangle(finer_, c1 - 1, r1 - 1, t);
                raise_forward_(big.cube, travel(preimage, big) + finer_forward_(preimage.cube));
            }
        }
        if (!all_coarse)
            for (const Triangle& small : std::span(fine, count)) raise_coverage_(small.cube, collapse_bound(small));
    }

    // Whether the cell is two by two finer cells of equal size, both coarse triangles present: then
    // every finer triangle lies in one coarse triangle, and the gap peaks at the nine finer vertices.
    bool nested(size_t c, size_t r, size_t c0, size_t r0, size_t c1, size_t r1) const {
        if (c1 - c0 != 2 || r1 - r0 != 2) return false;
        if (coarse_.cube[2 * coarse_.cell(c, r)] == kNoTriangle || coarse_.cube[2 * coarse_.cell(c, r) + 1] == kNoTriangle) return false;
        return finer_.columns[c0 + 1] - finer_.columns[c0] == finer_.columns[c1] - finer_.columns[c0 + 1] &&
               finer_.rows[r0 + 1] - finer_.rows[r0] == finer_.rows[r1] - finer_.rows[r0 + 1];
    }

    // The common case: a finer vertex at a coarse corner against that corner, one halfway along a
    // coarse edge (the cell's sides and its diagonal) against the edge's midpoint.
    void whole_cell(size_t c, size_t r, size_t c0, size_t r0, std::span<const Triangle> fine) {
        const double* corner[2][2] = {{coarse_.at(coarse_.vertex(c, r)), coarse_.at(coarse_.vertex(c, r + 1))},
                                      {coarse_.at(coarse_.vertex(c + 1, r)), coarse_.at(coarse_.vertex(c + 1, r + 1))}};
        double worst = 0;
        for (int j = 0; j <= 2; ++j)
            for (int i = 0; i <= 2; ++i) {
                // The coarse point halfway between the corners nearest (i, j): on a side, or the diagonal at the centre.
                const int ia = i / 2, ja = j / 2, ib = (i + 1) / 2, jb = (j + 1) / 2;
                const double *a = corner[ia][ja], *b = corner[ib][jb];
                const double expected[3] = {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
                worst = std::max(worst, distance(finer_.at(finer_.vertex(c0 + size_t(i), r0 + size_t(j))), expected));
            }
        double finer_worst = 0;
        for (const Triangle& small : fine) {
            raise_coverage_(small.cube, worst);
            finer_worst = std::max(finer_worst, finer_forward_(small.cube));
        }
        for (int t = 0; t < 2; ++t) raise_forward_(coarse_.cube[2 * coarse_.cell(c, r) + t], worst + finer_worst);
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
        const std::vector<uint64_t> &columns = finer_.columns.index, &rows = finer_.rows.index;
        const size_t fc = size_t(std::lower_bound(columns.begin(), columns.end(), uint64_t(param[0])) - columns.begin());
        const size_t fr = size_t(std::lower_bound(rows.begin(), rows.end(), uint64_t(param[1])) - rows.begin());
        return coarse_.vertex(finer_.columns.parent(fc), finer_.rows.parent(fr));
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
    // searched in rings around where it collapsed; the model's diagonal when none is near. Two rings: a
    // tiled build reads that far, and more, around each tile (terrain_build.cpp, kMarginCells).
    double nearest_used(const Triangle& small, uint64_t around) const {
        constexpr int64_t kRings = 2;
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
    const double far_;
    StepBound out_;
    Forward finer_forward_;
    Raise raise_forward_, raise_coverage_;
};

}  // namespace

StepBound bound_step(const TerrainLevel& finer, const TerrainLevel& coarse, const CubeDistances& finer_forward, double far) {
    return StepBounder(finer, coarse, finer_forward, far).run();
}

}  // namespace strata::terrain
