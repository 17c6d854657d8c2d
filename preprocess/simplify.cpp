#include "preprocess/simplify.h"

#include "preprocess/quadric.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <numeric>

namespace strata {
namespace {

// An open boundary of the model is kept in shape by planes through its edges, perpendicular to the
// surface, weighted well above the faces (DESIGN.md §2: not locked, but expensive to move).
constexpr float kBoundaryWeight = 10.0f;

// A collapse whose triangles turn by more than this (cosine of the angle) is refused: it would fold.
constexpr float kMinNormalCosine = 0.0f;

enum class Kind : uint8_t { manifold, border, seam, locked };

// Triangles around each point, rebuilt every pass from the live triangles (compressed rows).
struct Adjacency {
    std::vector<uint32_t> offsets;
    std::vector<uint32_t> triangles;

    void build(const std::vector<uint32_t>& tris, const std::vector<uint32_t>& wedge_point, uint32_t points) {
        offsets.assign(points + 1, 0);
        for (uint32_t w : tris) ++offsets[wedge_point[w] + 1];
        std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
        triangles.resize(tris.size());
        std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
        for (size_t i = 0; i < tris.size(); ++i) triangles[fill[wedge_point[tris[i]]]++] = uint32_t(i / 3);
    }
    const uint32_t* begin(uint32_t p) const { return triangles.data() + offsets[p]; }
    const uint32_t* end(uint32_t p) const { return triangles.data() + offsets[p + 1]; }
};

struct Candidate {
    float cost;
    uint32_t from;
    uint32_t to;
};

struct WedgePair {
    uint32_t from, to;
};

class BlockSimplifier {
public:
    BlockSimplifier(const BlockMesh& mesh, const SimplifyLimits& limits)
        : mesh_(mesh), limits_(limits), tris_(mesh.triangles), attribute_count_(mesh.attribute_count) {}

    SimplifyResult run();

private:
    Vec3 position(uint32_t point) const {
        const float* p = &mesh_.point_positions[3 * point];
        return {p[0], p[1], p[2]};
    }
    uint32_t point_of(uint32_t wedge) const { return mesh_.wedge_point[wedge]; }
    uint32_t corner_point(uint32_t tri, uint32_t corner) const { return point_of(tris_[3 * tri + corner]); }
    int corner_of(uint32_t tri, uint32_t point) const {
        for (int c = 0; c < 3; ++c)
            if (corner_point(tri, c) == point) return c;
        return -1;
    }

    void init_quadrics();
    void init_attributes();
    void classify();
    bool has_half_edge(uint32_t from, uint32_t to) const;
    bool find_partners(uint32_t u, uint32_t w, std::vector<WedgePair>& pairs) const;
    float attribute_error(uint32_t from, uint32_t to) const;
    bool best_candidate(uint32_t u, Candidate& best);
    bool within_travel(uint32_t u, uint32_t w) const;
    bool keeps_link(uint32_t u, uint32_t w);
    bool flips(uint32_t u, uint32_t w) const;
    uint32_t collapse(uint32_t u, uint32_t w);
    uint32_t run_pass();
    void compact_triangles();

    const BlockMesh& mesh_;
    SimplifyLimits limits_;
    std::vector<uint32_t> tris_;
    uint32_t attribute_count_;

    std::vector<Quadric> quadrics_;         // per point
    std::vector<float> moments_;            // per wedge: area, area·a[k], area·|a|²
    std::vector<float> box_;                // per point: lo xyz, hi xyz of all points merged into it
    std::vector<float> error_;              // per point
    std::vector<uint32_t> wedge_remap_;     // per wedge
    std::vector<uint32_t> point_remap_;     // per point, this pass
    std::vector<Kind> kind_;
    std::vector<uint8_t> pass_locked_;
    Adjacency adjacency_;
    std::vector<WedgePair> pairs_;          // scratch
    std::vector<uint32_t> neighbours_;      // scratch
};

void BlockSimplifier::init_quadrics() {
    quadrics_.assign(mesh_.point_count(), Quadric{});
    for (uint32_t t = 0; t < mesh_.triangle_count(); ++t) {
        Vec3 p0 = position(corner_point(t, 0)), p1 = position(corner_point(t, 1)), p2 = position(corner_point(t, 2));
        Vec3 n = cross(p1 - p0, p2 - p0);
        float twice_area = length(n);
        if (twice_area == 0) continue;
        n = n * (1.0f / twice_area);
        for (int c = 0; c < 3; ++c) quadrics_[corner_point(t, c)].add_plane(n, -dot(n, p0), 0.5f * twice_area);
    }
    // Boundary edges: a plane through the edge, perpendicular to its face.
    for (uint32_t t = 0; t < mesh_.triangle_count(); ++t) {
        for (int c = 0; c < 3; ++c) {
            uint32_t a = corner_point(t, c), b = corner_point(t, (c + 1) % 3);
            if (has_half_edge(b, a)) continue;
            Vec3 pa = position(a), pb = position(b), pc = position(corner_point(t, (c + 2) % 3));
            Vec3 edge = pb - pa;
            Vec3 face = cross(edge, pc - pa);
            Vec3 n = cross(edge, face);
            float len = length(n);
            if (len == 0) continue;
            n = n * (1.0f / len);
            float w = kBoundaryWeight * dot(edge, edge);
            quadrics_[a].add_plane(n, -dot(n, pa), w);
            quadrics_[b].add_plane(n, -dot(n, pa), w);
        }
    }
}

void BlockSimplifier::init_attributes() {
    const uint32_t stride = attribute_count_ + 2;
    moments_.assign(size_t(mesh_.wedge_count()) * stride, 0.0f);
    if (attribute_count_ == 0) return;
    for (uint32_t t = 0; t < mesh_.triangle_count(); ++t) {
        Vec3 p0 = position(corner_point(t, 0)), p1 = position(corner_point(t, 1)), p2 = position(corner_point(t, 2));
        float area = length(cross(p1 - p0, p2 - p0)) * (0.5f / 3.0f);
        for (int c = 0; c < 3; ++c) {
            uint32_t w = tris_[3 * t + c];
            const float* a = &mesh_.wedge_attributes[size_t(w) * attribute_count_];
            float* m = &moments_[size_t(w) * stride];
            m[0] += area;
            for (uint32_t k = 0; k < attribute_count_; ++k) {
                m[1 + k] += area * a[k];
                m[1 + attribute_count_] += area * a[k] * a[k];
            }
        }
    }
}

// Σ area·|a_i − a_to|² over the wedges merged into `from`, from its moments and the target's value.
float BlockSimplifier::attribute_error(uint32_t from, uint32_t to) const {
    const uint32_t stride = attribute_count_ + 2;
    const float* m = &moments_[size_t(from) * stride];
    const float* a = &mesh_.wedge_attributes[size_t(to) * attribute_count_];
    float e = m[1 + attribute_count_];
    for (uint32_t k = 0; k < attribute_count_; ++k) e += a[k] * (m[0] * a[k] - 2 * m[1 + k]);
    return e > 0 ? e : 0;
}

bool BlockSimplifier::has_half_edge(uint32_t from, uint32_t to) const {
    for (const uint32_t* t = adjacency_.begin(from); t != adjacency_.end(from); ++t) {
        int c = corner_of(*t, from);
        if (corner_point(*t, (c + 1) % 3) == to) return true;
    }
    return false;
}

void BlockSimplifier::classify() {
    const uint32_t points = mesh_.point_count();
    kind_.assign(points, Kind::manifold);
    for (uint32_t u = 0; u < points; ++u) {
        if (mesh_.point_locked[u]) {
            kind_[u] = Kind::locked;
            continue;
        }
        int out_open = 0, in_open = 0;
        bool complex = false, seam = false;
        uint32_t first_wedge = ~0u;
        for (const uint32_t* t = adjacency_.begin(u); t != adjacency_.end(u); ++t) {
            int c = corner_of(*t, u);
            uint32_t next = corner_point(*t, (c + 1) % 3), prev = corner_point(*t, (c + 2) % 3);
            uint32_t wedge = tris_[3 * *t + c];
            if (first_wedge == ~0u) first_wedge = wedge;
            seam |= wedge != first_wedge;
            int same = 0;
            for (const uint32_t* s = adjacency_.begin(u); s != adjacency_.end(u); ++s)
                same += corner_point(*s, (corner_of(*s, u) + 1) % 3) == next;
            complex |= same > 1;
            out_open += !has_half_edge(next, u);
            in_open += !has_half_edge(u, prev);
        }
        if (complex || out_open > 1 || out_open != in_open) kind_[u] = Kind::locked;
        else if (out_open == 1) kind_[u] = Kind::border;
        else if (seam) kind_[u] = Kind::seam;
    }
}

// Pairs each wedge of u with the wedge of w across a shared triangle edge; false if one has none or two.
bool BlockSimplifier::find_partners(uint32_t u, uint32_t w, std::vector<WedgePair>& pairs) const {
    pairs.clear();
    for (const uint32_t* t = adjacency_.begin(u); t != adjacency_.end(u); ++t) {
        int cw = corner_of(*t, w);
        if (cw < 0) continue;
        WedgePair pair{tris_[3 * *t + corner_of(*t, u)], tris_[3 * *t + cw]};
        bool known = false;
        for (const WedgePair& p : pairs) {
            if (p.from != pair.from) continue;
            if (p.to != pair.to) return false;
            known = true;
        }
        if (!known) pairs.push_back(pair);
    }
    if (pairs.empty()) return false;
    // Every wedge of u must have found its partner.
    for (const uint32_t* t = adjacency_.begin(u); t != adjacency_.end(u); ++t) {
        uint32_t wedge = tris_[3 * *t + corner_of(*t, u)];
        if (std::none_of(pairs.begin(), pairs.end(), [&](const WedgePair& p) { return p.from == wedge; }))
            return false;
    }
    return true;
}

bool BlockSimplifier::within_travel(uint32_t u, uint32_t w) const {
    const float* b = &box_[6 * u];
    Vec3 p = position(w);
    float d = std::max({p.x - b[0], p.y - b[1], p.z - b[2], b[3] - p.x, b[4] - p.y, b[5] - p.z});
    return d <= limits_.max_travel;
}

// The cheapest legal collapse of u into one of its neighbours.
bool BlockSimplifier::best_candidate(uint32_t u, Candidate& best) {
    Kind kind = kind_[u];
    if (kind == Kind::locked) return false;
    bool found = false;
    auto consider = [&](uint32_t w) {
        if (kind == Kind::border && (has_half_edge(u, w) == has_half_edge(w, u))) return;  // along the boundary only
        if (!within_travel(u, w)) return;
        if (!find_partners(u, w, pairs_)) return;
        float cost = quadrics_[u].evaluate(position(w));
        for (const WedgePair& p : pairs_) cost += attribute_error(p.from, p.to);
        cost /= quadrics_[u].weight > 0 ? quadrics_[u].weight : 1.0f;
        if (!found || cost < best.cost || (cost == best.cost && w < best.to)) best = {cost, u, w};
        found = true;
    };
    for (const uint32_t* t = adjacency_.begin(u); t != adjacency_.end(u); ++t) {
        int c = corner_of(*t, u);
        consider(corner_point(*t, (c + 1) % 3));
        if (kind == Kind::border) consider(corner_point(*t, (c + 2) % 3));
    }
    return found;
}

// Link condition: u and w may share no neighbour other than the apexes of the triangles on edge uw;
// otherwise the collapse pinches the surface into a non-manifold edge.
bool BlockSimplifier::keeps_link(uint32_t u, uint32_t w) {
    neighbours_.clear();
    int apexes = 0;
    for (const uint32_t* t = adjacency_.begin(u); t != adjacency_.end(u); ++t) {
        bool on_edge = corner_of(*t, w) >= 0;
        apexes += on_edge;
        for (int c = 0; c < 3; ++c) {
            uint32_t p = point_remap_[corner_point(*t, c)];
            if (p != u && p != w) neighbours_.push_back(p);
        }
    }
    std::sort(neighbours_.begin(), neighbours_.end());
    neighbours_.erase(std::unique(neighbours_.begin(), neighbours_.end()), neighbours_.end());
    int shared = 0;
    for (const uint32_t* t = adjacency_.begin(w); t != adjacency_.end(w); ++t) {
        for (int c = 0; c < 3; ++c) {
            uint32_t p = point_remap_[corner_point(*t, c)];
            if (p == u || p == w) continue;
            if (std::binary_search(neighbours_.begin(), neighbours_.end(), p)) {
                ++shared;
                neighbours_.erase(std::lower_bound(neighbours_.begin(), neighbours_.end(), p));
            }
        }
    }
    return shared == apexes;
}

// Would moving u onto w turn any of u's remaining triangles over (or flatten it to nothing)?
bool BlockSimplifier::flips(uint32_t u, uint32_t w) const {
    Vec3 target = position(w);
    for (const uint32_t* t = adjacency_.begin(u); t != adjacency_.end(u); ++t) {
        if (corner_of(*t, w) >= 0) continue;  // collapses away
        int c = corner_of(*t, u);
        Vec3 a = position(u);
        Vec3 b = position(point_remap_[corner_point(*t, (c + 1) % 3)]);
        Vec3 d = position(point_remap_[corner_point(*t, (c + 2) % 3)]);
        Vec3 before = cross(b - a, d - a);
        Vec3 after = cross(b - target, d - target);
        float cosine = dot(before, after);
        float scale = length(before) * length(after);
        if (scale == 0 || cosine <= kMinNormalCosine * scale) return true;
    }
    return false;
}

// Moves u onto w; returns how many triangles it removes.
uint32_t BlockSimplifier::collapse(uint32_t u, uint32_t w) {
    const uint32_t stride = attribute_count_ + 2;
    for (const WedgePair& p : pairs_) {
        wedge_remap_[p.from] = p.to;
        if (attribute_count_)
            for (uint32_t k = 0; k < stride; ++k) moments_[size_t(p.to) * stride + k] += moments_[size_t(p.from) * stride + k];
    }
    float geometric = std::sqrt(quadrics_[u].evaluate(position(w)) / std::max(quadrics_[u].weight, 1e-30f));
    quadrics_[w].add(quadrics_[u]);
    for (int k = 0; k < 3; ++k) {
        box_[6 * w + k] = std::min(box_[6 * w + k], box_[6 * u + k]);
        box_[6 * w + 3 + k] = std::max(box_[6 * w + 3 + k], box_[6 * u + 3 + k]);
    }
    error_[w] = std::max({error_[w], error_[u], geometric});
    point_remap_[u] = w;
    uint32_t removed = 0;
    for (const uint32_t* t = adjacency_.begin(u); t != adjacency_.end(u); ++t) removed += corner_of(*t, w) >= 0;
    return removed;
}

uint32_t BlockSimplifier::run_pass() {
    const uint32_t points = mesh_.point_count();
    adjacency_.build(tris_, mesh_.wedge_point, points);
    classify();

    std::vector<Candidate> candidates;
    candidates.reserve(points);
    for (uint32_t u = 0; u < points; ++u) {
        Candidate c;
        if (adjacency_.offsets[u] != adjacency_.offsets[u + 1] && best_candidate(u, c)) candidates.push_back(c);
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.cost < b.cost || (a.cost == b.cost && a.from < b.from);
    });

    // Each collapse locks its two points for the pass, so many candidates get skipped; allow the pass
    // somewhat more error than the cheapest goal-many collapses would need (as meshoptimizer does).
    const uint32_t live = uint32_t(tris_.size() / 3);
    const uint32_t goal = live > limits_.target_triangles ? live - limits_.target_triangles : 0;
    const size_t edge_goal = goal / 2;
    float cost_bound = edge_goal < candidates.size() ? 1.5f * candidates[edge_goal].cost : 1e30f;

    pass_locked_.assign(points, 0);
    std::iota(point_remap_.begin(), point_remap_.end(), 0u);
    uint32_t removed = 0;
    for (const Candidate& c : candidates) {
        if (removed >= goal) break;
        if (c.cost > cost_bound && removed > 0) break;
        if (pass_locked_[c.from] || pass_locked_[c.to]) continue;
        float geometric = std::sqrt(quadrics_[c.from].evaluate(position(c.to)) /
                                    std::max(quadrics_[c.from].weight, 1e-30f));
        if (geometric > limits_.max_error) continue;
        if (!keeps_link(c.from, c.to) || flips(c.from, c.to)) continue;
        if (!find_partners(c.from, c.to, pairs_)) continue;
        removed += collapse(c.from, c.to);
        pass_locked_[c.from] = pass_locked_[c.to] = 1;
    }
    if (removed) compact_triangles();
    return removed;
}

void BlockSimplifier::compact_triangles() {
    size_t out = 0;
    for (size_t t = 0; t < tris_.size(); t += 3) {
        uint32_t a = wedge_remap_[tris_[t]], b = wedge_remap_[tris_[t + 1]], c = wedge_remap_[tris_[t + 2]];
        uint32_t pa = point_of(a), pb = point_of(b), pc = point_of(c);
        if (pa == pb || pb == pc || pa == pc) continue;
        tris_[out++] = a, tris_[out++] = b, tris_[out++] = c;
    }
    tris_.resize(out);
}

SimplifyResult BlockSimplifier::run() {
    const uint32_t points = mesh_.point_count();
    adjacency_.build(tris_, mesh_.wedge_point, points);
    init_quadrics();
    init_attributes();
    box_.resize(6 * size_t(points));
    for (uint32_t p = 0; p < points; ++p)
        for (int k = 0; k < 3; ++k) box_[6 * p + k] = box_[6 * p + 3 + k] = mesh_.point_positions[3 * p + k];
    error_.assign(points, 0.0f);
    wedge_remap_.resize(mesh_.wedge_count());
    std::iota(wedge_remap_.begin(), wedge_remap_.end(), 0u);
    point_remap_.resize(points);

    while (tris_.size() / 3 > limits_.target_triangles && run_pass() > 0) {
    }

    // Compose collapse chains: v → u in one pass and u → w in a later one make P(v) = w.
    SimplifyResult result;
    result.wedge_remap = wedge_remap_;
    for (uint32_t& target : result.wedge_remap)
        while (result.wedge_remap[target] != target) target = result.wedge_remap[target];
    result.point_error = std::move(error_);
    result.triangles_left = uint32_t(tris_.size() / 3);
    return result;
}

}  // namespace

SimplifyResult simplify_block(const BlockMesh& mesh, const SimplifyLimits& limits) {
    return BlockSimplifier(mesh, limits).run();
}

}  // namespace strata
