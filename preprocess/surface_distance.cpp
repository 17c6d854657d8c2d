#include "preprocess/surface_distance.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace strata {
namespace {

struct D3 {
    double x, y, z;
};
D3 operator-(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
D3 operator+(D3 a, D3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
D3 operator*(D3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
D3 cross(D3 a, D3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double length(D3 a) { return std::sqrt(dot(a, a)); }
D3 midpoint(D3 a, D3 b) { return (a + b) * 0.5; }

D3 load(const double p[3]) { return {p[0], p[1], p[2]}; }

// Ericson, Real-Time Collision Detection §5.1.5: the closest point by Voronoi region.
D3 closest_on_triangle(D3 p, D3 a, D3 b, D3 c) {
    const D3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return a;
    const D3 bp = p - b;
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
    const D3 cp = p - c;
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    const double sum = va + vb + vc;
    if (!(sum > 0)) {  // a degenerate triangle: its longest edge holds all of it
        const D3 bc = c - b;
        const double lab = dot(ab, ab), lac = dot(ac, ac), lbc = dot(bc, bc);
        const D3 from = lbc > lab && lbc > lac ? b : a, along = lbc > lab && lbc > lac ? bc : lac > lab ? ac : ab;
        const double span = dot(along, along);
        return span > 0 ? from + along * std::clamp(dot(p - from, along) / span, 0.0, 1.0) : a;
    }
    return a + ab * (vb / sum) + ac * (vc / sum);
}

double triangle_distance(D3 p, D3 a, D3 b, D3 c) { return length(p - closest_on_triangle(p, a, b, c)); }

// The corners of triangle t of a surface, in double.
std::array<D3, 3> corners(SurfaceView s, uint32_t t) {
    std::array<D3, 3> out;
    for (int k = 0; k < 3; ++k) {
        const float* x = &s.positions[3 * size_t(s.triangles[3 * size_t(t) + k])];
        out[size_t(k)] = {x[0], x[1], x[2]};
    }
    return out;
}

double box_distance(D3 p, const float lo[3], const float hi[3]) {
    const double q[3] = {p.x, p.y, p.z};
    double squared = 0;
    for (int a = 0; a < 3; ++a) {
        const double d = std::max({double(lo[a]) - q[a], q[a] - double(hi[a]), 0.0});
        squared += d * d;
    }
    return std::sqrt(squared);
}

// 2D convex polygons for the height-field bound, counter-clockwise, in fixed storage: a triangle
// clipped by a triangle has at most six corners.
struct P2 {
    double u, v;
};
struct Polygon {
    std::array<P2, 8> p;
    int n = 0;
};
// A clipped part of a target triangle, and which triangle.
struct Part {
    Polygon polygon;
    uint32_t target;
};

double cross2(P2 o, P2 a, P2 b) { return (a.u - o.u) * (b.v - o.v) - (a.v - o.v) * (b.u - o.u); }

double area(const Polygon& poly) {
    double twice = 0;
    for (int i = 0; i < poly.n; ++i) {
        const P2 a = poly.p[size_t(i)], b = poly.p[size_t((i + 1) % poly.n)];
        twice += a.u * b.v - a.v * b.u;
    }
    return 0.5 * twice;
}

bool boxes_meet(const Polygon& a, const Polygon& b) {
    auto extent = [](const Polygon& poly, double lo[2], double hi[2]) {
        lo[0] = lo[1] = INFINITY, hi[0] = hi[1] = -INFINITY;
        for (int i = 0; i < poly.n; ++i) {
            lo[0] = std::min(lo[0], poly.p[size_t(i)].u), hi[0] = std::max(hi[0], poly.p[size_t(i)].u);
            lo[1] = std::min(lo[1], poly.p[size_t(i)].v), hi[1] = std::max(hi[1], poly.p[size_t(i)].v);
        }
    };
    double alo[2], ahi[2], blo[2], bhi[2];
    extent(a, alo, ahi), extent(b, blo, bhi);
    return alo[0] <= bhi[0] && blo[0] <= ahi[0] && alo[1] <= bhi[1] && blo[1] <= ahi[1];
}

// Sutherland–Hodgman: the part of the triangle `subject` left of every edge of the triangle `clip`.
Polygon clip_triangle(const Polygon& subject, const Polygon& clip) {
    Polygon out = subject, in;
    for (int e = 0; e < 3 && out.n > 0; ++e) {
        const P2 a = clip.p[size_t(e)], b = clip.p[size_t((e + 1) % 3)];
        in = out;
        out.n = 0;
        for (int i = 0; i < in.n; ++i) {
            const P2 p = in.p[size_t(i)], q = in.p[size_t((i + 1) % in.n)];
            const double sp = cross2(a, b, p), sq = cross2(a, b, q);
            if (sp >= 0) out.p[size_t(out.n++)] = p;
            if ((sp >= 0) != (sq >= 0)) out.p[size_t(out.n++)] = {p.u + (q.u - p.u) * (sp / (sp - sq)), p.v + (q.v - p.v) * (sp / (sp - sq))};
        }
    }
    return out;
}

// Whether two convex polygons overlap by more than `slack` along every axis (separating axes: the
// edge normals of both). Polygons that only share an edge do not.
bool polygons_overlap(const Polygon& a, const Polygon& b, double slack) {
    for (const Polygon* edges : {&a, &b})
        for (int e = 0; e < edges->n; ++e) {
            const P2 p = edges->p[size_t(e)], q = edges->p[size_t((e + 1) % edges->n)];
            const double nu = q.v - p.v, nv = p.u - q.u, scale_squared = nu * nu + nv * nv;
            if (!(scale_squared > 0)) continue;
            auto extent = [&](const Polygon& poly, double& lo, double& hi) {
                lo = INFINITY, hi = -INFINITY;
                for (int i = 0; i < poly.n; ++i) {
                    const double x = poly.p[size_t(i)].u * nu + poly.p[size_t(i)].v * nv;
                    lo = std::min(lo, x), hi = std::max(hi, x);
                }
            };
            double alo, ahi, blo, bhi;
            extent(a, alo, ahi), extent(b, blo, bhi);
            const double depth = std::min(ahi, bhi) - std::max(alo, blo);  // along the axis, times its length
            if (depth <= 0 || depth * depth <= slack * slack * scale_squared) return false;
        }
    return true;
}

// Facing target triangles steeper than this against a piece are left out of its height field: they
// cover little in projection and would make the graph ill-conditioned.
constexpr double kMinFacing = 0.2;
// A piece's height field must cover all of it but what rounding leaves (a relative area); beyond
// that the target has a hole or an edge under the piece, and the piece splits instead.
constexpr double kMaxUncovered = 1e-9;

double smallest_angle(const Polygon& t) {
    double least = M_PI;
    for (size_t i = 0; i < 3; ++i) {
        const P2 o = t.p[i], a = t.p[(i + 1) % 3], b = t.p[(i + 2) % 3];
        const double ua = a.u - o.u, va = a.v - o.v, ub = b.u - o.u, vb = b.v - o.v;
        least = std::min(least, std::atan2(std::fabs(ua * vb - va * ub), ua * ub + va * vb));
    }
    return least;
}

double least_altitude(const Polygon& t, double triangle_area) {
    double longest = 0;
    for (size_t i = 0; i < 3; ++i) longest = std::max(longest, std::hypot(t.p[(i + 1) % 3].u - t.p[i].u, t.p[(i + 1) % 3].v - t.p[i].v));
    return 2 * triangle_area / longest;
}

class Bounder {
public:
    Bounder(const TriangleTree& to, double tolerance) : to_(to), tolerance_(tolerance) {}

    struct Corner {
        D3 p;
        TriangleTree::Nearest nearest;
    };
    Corner corner(D3 p) const {
        const double q[3] = {p.x, p.y, p.z};
        return {p, to_.nearest(q)};
    }

    // The bound of one triangle of X given its corners, folded into its group's.
    void bound_triangle(const Corner& a, const Corner& b, const Corner& c, DistanceBound& group) {
        stack_.clear();
        stack_.push_back({{a, b, c}, 0});
        while (!stack_.empty()) {
            const Piece piece = stack_.back();
            stack_.pop_back();
            for (const Corner& k : piece.c) group.lower = std::max(group.lower, k.nearest.distance);
            const double settled = group.lower + tolerance_;
            double upper = std::min(lipschitz(piece.c), one_target(piece.c));
            if (upper > settled) upper = std::min(upper, height_field(piece.c, upper));
            if (upper <= settled || piece.depth >= kMaxDepth) {
                group.upper = std::max(group.upper, upper);
                continue;
            }
            const Corner m01 = corner(midpoint(piece.c[0].p, piece.c[1].p));
            const Corner m12 = corner(midpoint(piece.c[1].p, piece.c[2].p));
            const Corner m20 = corner(midpoint(piece.c[2].p, piece.c[0].p));
            const int d = piece.depth + 1;
            stack_.push_back({{piece.c[0], m01, m20}, d});
            stack_.push_back({{m01, piece.c[1], m12}, d});
            stack_.push_back({{m20, m12, piece.c[2]}, d});
            stack_.push_back({{m01, m12, m20}, d});
        }
    }

private:
    static constexpr int kMaxDepth = 12;
    struct Piece {
        Corner c[3];
        int depth;
    };

    // Every point of the piece is within its longest edge of each corner (a triangle's farthest point
    // from a corner is another corner).
    static double lipschitz(const Corner (&c)[3]) {
        double best = std::numeric_limits<double>::infinity();
        for (int i = 0; i < 3; ++i) {
            const double reach = std::max(length(c[i].p - c[(i + 1) % 3].p), length(c[i].p - c[(i + 2) % 3].p));
            best = std::min(best, c[i].nearest.distance + reach);
        }
        return best;
    }

    // Each corner's nearest triangle, tried for the whole piece.
    double one_target(const Corner (&c)[3]) const {
        double best = std::numeric_limits<double>::infinity();
        for (int i = 0; i < 3; ++i) {
            const uint32_t target = c[i].nearest.triangle;
            if (target == ~0u) continue;
            const std::array<D3, 3> y = corners(to_.surface(), target);
            double worst = 0;
            for (int k = 0; k < 3; ++k) worst = std::max(worst, triangle_distance(c[k].p, y[0], y[1], y[2]));
            best = std::min(best, worst + to_.offset(target));
        }
        return best;
    }

    // The vertical gap to the facing part of Y above the piece, or +inf when it is not a graph there.
    // `reach` bounds how far that part can be: any point of the piece is within it of Y. The corners'
    // nearest triangles cover most pieces on their own; only when they do not is Y searched.
    double height_field(const Corner (&c)[3], double reach) {
        const D3 e1raw = c[1].p - c[0].p, normal_raw = cross(e1raw, c[2].p - c[0].p);
        const double twice_area = length(normal_raw), e1_length = length(e1raw);
        const double inf = std::numeric_limits<double>::infinity();
        if (!(twice_area > 0) || !(e1_length > 0)) return inf;
        frame_.origin = c[0].p;
        frame_.n = normal_raw * (1 / twice_area);
        frame_.e1 = e1raw * (1 / e1_length);
        frame_.e2 = cross(frame_.n, frame_.e1);
        frame_.reach = reach;
        frame_.piece = {{frame_.flat(c[0].p), frame_.flat(c[1].p), frame_.flat(c[2].p)}, 3};
        const double piece_area = 0.5 * twice_area;

        start_cover();
        quick_.clear();
        for (const Corner& k : c) add_neighbourhood(k);
        std::sort(quick_.begin(), quick_.end());
        quick_.erase(std::unique(quick_.begin(), quick_.end()), quick_.end());
        for (uint32_t target : quick_) cover_with(target);
        const double quick = cover_bound(piece_area);
        if (quick < inf) return quick;

        const D3 n = frame_.n;
        const double grow[3] = {reach * std::fabs(n.x), reach * std::fabs(n.y), reach * std::fabs(n.z)};
        const double q[3][3] = {{c[0].p.x, c[0].p.y, c[0].p.z}, {c[1].p.x, c[1].p.y, c[1].p.z}, {c[2].p.x, c[2].p.y, c[2].p.z}};
        double lo[3], hi[3];  // the prism over the piece, `reach` either side: where the part of Y that matters lies
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min({q[0][a], q[1][a], q[2][a]}) - grow[a];
            hi[a] = std::max({q[0][a], q[1][a], q[2][a]}) + grow[a];
        }
        start_cover();
        to_.overlapping(lo, hi, [&](uint32_t target) { cover_with(target); });
        return cover_bound(piece_area);
    }

    // A corner's nearest triangle, and where the nearest point is one of its vertices or edges, the
    // triangles around that vertex or across that edge: what a piece near the corner lies over.
    void add_neighbourhood(const Corner& k) {
        const uint32_t t = k.nearest.triangle;
        if (t == ~0u) return;
        quick_.push_back(t);
        const std::array<D3, 3> y = corners(to_.surface(), t);
        const D3 q = closest_on_triangle(k.p, y[0], y[1], y[2]);
        const D3 cr = cross(y[1] - y[0], y[2] - y[0]);
        const double twice = dot(cr, cr);
        if (!(twice > 0)) return;
        // Barycentric weights of q: a weight of 1 is a vertex, a weight of 0 the edge across.
        const double w[3] = {dot(cross(y[1] - q, y[2] - q), cr) / twice, dot(cross(y[2] - q, y[0] - q), cr) / twice,
                             dot(cross(y[0] - q, y[1] - q), cr) / twice};
        const uint32_t* v = &to_.surface().triangles[3 * size_t(t)];
        constexpr double kOn = 1e-9;
        for (int i = 0; i < 3; ++i) {
            if (w[i] >= 1 - kOn) {
                for (uint32_t u : to_.around(v[i])) quick_.push_back(u);
            } else if (w[i] <= kOn) {
                const uint32_t a = v[(i + 1) % 3], b = v[(i + 2) % 3];
                for (uint32_t u : to_.around(a)) {
                    const uint32_t* x = &to_.surface().triangles[3 * size_t(u)];
                    if (x[0] == b || x[1] == b || x[2] == b) quick_.push_back(u);
                }
            }
        }
    }

    void start_cover() { parts_.clear(), worst_ = 0, covered_ = 0; }

    // Adds the part of the piece that target triangle covers, if it faces the piece and is within reach.
    void cover_with(uint32_t target) {
        const float* ny = to_.normal(target);
        if (ny[0] * frame_.n.x + ny[1] * frame_.n.y + ny[2] * frame_.n.z < kMinFacing) return;
        const std::array<D3, 3> y = corners(to_.surface(), target);
        const Polygon projected{{frame_.flat(y[0]), frame_.flat(y[1]), frame_.flat(y[2])}, 3};
        if (!boxes_meet(frame_.piece, projected)) return;
        const double projected_area = area(projected);
        if (!(projected_area > 0)) return;
        const Polygon part = clip_triangle(frame_.piece, projected);
        if (part.n < 3) return;
        const double part_area = area(part);
        if (!(part_area > 0)) return;
        // Height of Y's plane over a point of the piece's plane, by barycentric interpolation.
        const double h[3] = {frame_.height(y[0]), frame_.height(y[1]), frame_.height(y[2])};
        double gap = 0;
        for (int k = 0; k < part.n; ++k) {
            const P2 p = part.p[size_t(k)];
            const double b0 = cross2(projected.p[1], projected.p[2], p), b1 = cross2(projected.p[2], projected.p[0], p);
            const double b2 = 2 * projected_area - b0 - b1;
            gap = std::max(gap, std::fabs((b0 * h[0] + b1 * h[1] + b2 * h[2]) / (2 * projected_area)));
        }
        if (gap > frame_.reach) return;  // another layer, farther than the piece can be from Y
        worst_ = std::max(worst_, gap + to_.offset(target));
        covered_ += part_area;
        parts_.push_back({part, target});
    }

    // The bound the cover gives, or +inf when it leaves more than rounding uncovered or overlaps.
    double cover_bound(double piece_area) const {
        const double uncovered = std::max(0.0, piece_area - covered_);
        if (uncovered > kMaxUncovered * piece_area || overlap(piece_area)) return std::numeric_limits<double>::infinity();
        // Rounding's slivers: an uncovered point at distance r from every covered one has the part of
        // the disc of radius r inside the piece uncovered, at least a corner's sector (α_min·r²/2)
        // while r is below the piece's least altitude.
        const double slack = std::sqrt(2 * uncovered / smallest_angle(frame_.piece));
        if (!(slack <= least_altitude(frame_.piece, piece_area))) return std::numeric_limits<double>::infinity();
        return worst_ + slack;
    }

    // Whether two of the clipped polygons overlap by more than rounding: then Y is not a graph over
    // the piece, and the covered area double counts. Two facing triangles that share an edge project
    // to its two sides: they need no test.
    bool overlap(double piece_area) const {
        const double slack = 1e-9 * std::sqrt(piece_area);
        for (size_t i = 0; i < parts_.size(); ++i)
            for (size_t j = i + 1; j < parts_.size(); ++j)
                if (!share_edge(parts_[i].target, parts_[j].target) &&
                    polygons_overlap(parts_[i].polygon, parts_[j].polygon, slack))
                    return true;
        return false;
    }
    bool share_edge(uint32_t a, uint32_t b) const {
        const uint32_t* x = &to_.surface().triangles[3 * size_t(a)];
        const uint32_t* y = &to_.surface().triangles[3 * size_t(b)];
        int common = 0;
        for (int i = 0; i < 3; ++i) common += x[i] == y[0] || x[i] == y[1] || x[i] == y[2];
        return common == 2;
    }

    const TriangleTree& to_;
    double tolerance_;
    // The piece's plane: 2D coordinates along e1, e2 and heights along n, from the piece's first corner.
    struct PieceFrame {
        D3 origin, n, e1, e2;
        double reach;
        Polygon piece;
        P2 flat(D3 p) const { return {dot(p - origin, e1), dot(p - origin, e2)}; }
        double height(D3 p) const { return dot(p - origin, n); }
    };
    PieceFrame frame_;
    std::vector<Part> parts_;  // the cover
    std::vector<uint32_t> quick_;
    double worst_ = 0, covered_ = 0;
    std::vector<Piece> stack_;
};

}  // namespace

double point_triangle_distance(const double p[3], const double a[3], const double b[3], const double c[3]) {
    return triangle_distance(load(p), load(a), load(b), load(c));
}

TriangleTree::TriangleTree(SurfaceView surface, std::span<const float> offsets) : surface_(surface), offsets_(offsets) {
    const uint32_t n = surface.triangle_count();
    if (n == 0) return;
    order_.resize(n);
    std::vector<float> centroids(3 * size_t(n));
    for (uint32_t t = 0; t < n; ++t) {
        order_[t] = t;
        const std::array<D3, 3> c = corners(surface, t);
        centroids[3 * size_t(t)] = float((c[0].x + c[1].x + c[2].x) / 3);
        centroids[3 * size_t(t) + 1] = float((c[0].y + c[1].y + c[2].y) / 3);
        centroids[3 * size_t(t) + 2] = float((c[0].z + c[1].z + c[2].z) / 3);
    }
    normals_.resize(3 * size_t(n));
    for (uint32_t t = 0; t < n; ++t) {
        const std::array<D3, 3> c = corners(surface, t);
        const D3 cr = cross(c[1] - c[0], c[2] - c[0]);
        const double l = length(cr);
        const D3 unit = l > 0 ? cr * (1 / l) : D3{0, 0, 0};  // a degenerate triangle faces nothing
        normals_[3 * size_t(t)] = float(unit.x), normals_[3 * size_t(t) + 1] = float(unit.y), normals_[3 * size_t(t) + 2] = float(unit.z);
    }
    const size_t vertices = surface.positions.size() / 3;
    around_first_.assign(vertices + 1, 0);
    for (uint32_t v : surface.triangles) ++around_first_[v + 1];
    for (size_t v = 0; v < vertices; ++v) around_first_[v + 1] += around_first_[v];
    around_.resize(surface.triangles.size());
    std::vector<uint32_t> fill(around_first_.begin(), around_first_.end() - 1);
    for (uint32_t t = 0; t < n; ++t)
        for (int k = 0; k < 3; ++k) around_[fill[surface.triangles[3 * size_t(t) + k]]++] = t;
    nodes_.reserve(2 * size_t(n));
    nodes_.resize(1);
    build(0, 0, n, centroids);
}

// Fills node `index` for triangles order_[begin, end): median split of the centroids on the box's
// longest axis, four triangles or fewer per leaf. An inner node's two children sit side by side.
void TriangleTree::build(uint32_t index, uint32_t begin, uint32_t end, const std::vector<float>& centroids) {
    Node node{};
    for (int a = 0; a < 3; ++a) node.lo[a] = std::numeric_limits<float>::infinity(), node.hi[a] = -node.lo[a];
    node.min_offset = std::numeric_limits<float>::infinity();
    for (uint32_t i = begin; i < end; ++i) {
        const uint32_t t = order_[i];
        for (int k = 0; k < 3; ++k) {
            const float* x = &surface_.positions[3 * size_t(surface_.triangles[3 * size_t(t) + k])];
            for (int a = 0; a < 3; ++a) node.lo[a] = std::min(node.lo[a], x[a]), node.hi[a] = std::max(node.hi[a], x[a]);
        }
        node.min_offset = std::min(node.min_offset, offsets_.empty() ? 0.0f : offsets_[t]);
    }
    if (end - begin <= 4) {
        node.first = begin, node.count = end - begin;
        nodes_[index] = node;
        return;
    }
    int axis = 0;
    for (int a = 1; a < 3; ++a)
        if (node.hi[a] - node.lo[a] > node.hi[axis] - node.lo[axis]) axis = a;
    const uint32_t middle = begin + (end - begin) / 2;
    std::nth_element(order_.begin() + begin, order_.begin() + middle, order_.begin() + end, [&](uint32_t a, uint32_t b) {
        const float ca = centroids[3 * size_t(a) + axis], cb = centroids[3 * size_t(b) + axis];
        return ca < cb || (ca == cb && a < b);
    });
    node.first = uint32_t(nodes_.size()), node.count = 0;
    nodes_[index] = node;
    nodes_.resize(nodes_.size() + 2);
    build(node.first, begin, middle, centroids);
    build(node.first + 1, middle, end, centroids);
}

TriangleTree::Nearest TriangleTree::nearest(const double point[3], uint32_t hint) const {
    Nearest best;
    if (nodes_.empty()) return best;
    const D3 p = load(point);
    if (hint < surface_.triangle_count()) {
        const std::array<D3, 3> c = corners(surface_, hint);
        best = {triangle_distance(p, c[0], c[1], c[2]) + offset(hint), hint};
    }
    struct Entry {
        uint32_t node;
        double distance;
    };
    Entry stack[64];
    uint32_t top = 0;
    stack[top++] = {0, 0};
    while (top) {
        const Entry e = stack[--top];
        if (e.distance >= best.distance) continue;
        const Node& n = nodes_[e.node];
        if (n.count) {
            for (uint32_t i = n.first; i < n.first + n.count; ++i) {
                const uint32_t t = order_[i];
                const std::array<D3, 3> c = corners(surface_, t);
                const double d = triangle_distance(p, c[0], c[1], c[2]) + offset(t);
                if (d < best.distance || (d == best.distance && t < best.triangle)) best = {d, t};
            }
            continue;
        }
        const Node& left = nodes_[n.first];
        const Node& right = nodes_[n.first + 1];
        const double dl = box_distance(p, left.lo, left.hi) + left.min_offset;
        const double dr = box_distance(p, right.lo, right.hi) + right.min_offset;
        // The nearer child last, so that it is searched first.
        if (dl < dr) {
            stack[top++] = {n.first + 1, dr};
            stack[top++] = {n.first, dl};
        } else {
            stack[top++] = {n.first, dl};
            stack[top++] = {n.first + 1, dr};
        }
    }
    return best;
}

std::vector<DistanceBound> directed_distance(SurfaceView from, std::span<const uint32_t> groups, uint32_t group_count,
                                             const TriangleTree& to, double tolerance) {
    std::vector<DistanceBound> out(group_count);
    if (to.empty()) {
        std::vector<uint8_t> used(group_count, 0);
        for (uint32_t g : groups) used[g] = 1;
        for (uint32_t g = 0; g < group_count; ++g)
            if (used[g]) out[g] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
        return out;
    }
    // Every vertex's distance first: each group's lower bound then starts near its maximum, and the
    // branch and bound settles most pieces at once.
    Bounder bounder(to, tolerance);
    std::vector<Bounder::Corner> at(from.positions.size() / 3);
    std::vector<uint8_t> known(at.size(), 0);
    for (size_t k = 0; k < from.triangles.size(); ++k) {
        const uint32_t v = from.triangles[k];
        if (!known[v]) {
            const float* x = &from.positions[3 * size_t(v)];
            at[v] = bounder.corner({x[0], x[1], x[2]}), known[v] = 1;
        }
        DistanceBound& group = out[groups[k / 3]];
        group.lower = std::max(group.lower, at[v].nearest.distance);
    }
    for (uint32_t t = 0; t < from.triangle_count(); ++t) {
        const uint32_t* v = &from.triangles[3 * size_t(t)];
        bounder.bound_triangle(at[v[0]], at[v[1]], at[v[2]], out[groups[t]]);
    }
    return out;
}

}  // namespace strata
