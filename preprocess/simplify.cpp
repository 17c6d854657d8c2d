#include "preprocess/simplify.h"

#include "preprocess/quadric.h"
#include "preprocess/radix_sort.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <numeric>

namespace strata {
namespace {

// An open boundary of the model is kept in shape by planes through its edges, perpendicular to the
// surface, weighted well above the faces (DESIGN.md §2: not locked, but expensive to move).
constexpr float kBoundaryWeight = 10.0f;
// A seam (one position, two attribute charts) is held in shape by edge planes too, on each side.
constexpr float kSeamWeight = 2.0f;

// A collapse whose triangles turn by more than this (cosine of the angle) is refused: it would fold.
constexpr float kMinNormalCosine = 0.0f;

enum class Kind : uint8_t { manifold, border, seam, locked };

inline uint32_t next_corner(uint32_t corner) { return corner % 3 == 2 ? corner - 2 : corner + 1; }
inline uint32_t prev_corner(uint32_t corner) { return corner % 3 == 0 ? corner + 2 : corner - 1; }

// One corner at a point, with the points of the two other corners of its triangle: the hot loops
// (link checks, candidate search) walk a point's fan without touching the corner arrays.
struct Link {
    uint32_t corner;  // 3·triangle + corner
    uint32_t next;    // point at next_corner(corner)
    uint32_t prev;    // point at prev_corner(corner)
};

// The corner of `link`'s triangle that sits on `point`, or ~0u (the lowest such corner, should a
// degenerate triangle hold it twice).
inline uint32_t corner_on(const Link& link, uint32_t point) {
    const uint32_t next = link.next == point ? next_corner(link.corner) : ~0u;
    const uint32_t prev = link.prev == point ? prev_corner(link.corner) : ~0u;
    return std::min(next, prev);
}

// The corners at each point, rebuilt every pass from the live triangles.
struct Adjacency {
    std::vector<uint32_t> offsets;
    std::vector<Link> links;
    std::vector<uint32_t> fill;

    void build(const std::vector<uint32_t>& corner_points, uint32_t points) {
        offsets.assign(points + 1, 0);
        for (uint32_t p : corner_points) ++offsets[p + 1];
        std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
        links.resize(corner_points.size());
        fill.assign(offsets.begin(), offsets.end() - 1);
        for (uint32_t i = 0; i < corner_points.size(); ++i)
            links[fill[corner_points[i]]++] = Link{i, corner_points[next_corner(i)], corner_points[prev_corner(i)]};
    }
    const Link* begin(uint32_t p) const { return links.data() + offsets[p]; }
    const Link* end(uint32_t p) const { return links.data() + offsets[p + 1]; }
};

// Per point, what the hot loops read at a point and at each of its neighbours, side by side: a link
// check or a flip test touches one cache line per neighbour, not one per array. The collapse loop
// visits points in cost order, all over the block, so the lines it touches are what it costs.
struct PointState {
    Vec3 position;
    uint32_t remap;         // this pass: the point it collapsed into, else itself
    uint32_t seen;          // stamp of the last link check that saw it
    uint32_t wedge;         // its one wedge, when single_wedge
    Kind kind;              // from the block as given
    uint8_t locked;         // may not move (block border); may be a target
    uint8_t single_wedge;   // all its corners carry one wedge
    uint8_t dirty;          // its best collapse must be looked at again
    uint8_t pass_locked;    // moved, or a target, this pass
    uint8_t has_best;       // best_ holds its best collapse
};

// Which points precede and follow a point u in its triangles, by stamps in per-point slots: marking
// u's fan and every lookup afterwards take time linear in u's valence, however high, and sort nothing.
class FanMarks {
public:
    void reset(uint32_t points) {
        slots_.assign(points, Slot{});
        stamp_ = 0;
    }
    // Marks u's fan; false if some point precedes u in two of its triangles, or follows it in two.
    bool mark(const Adjacency& adjacency, uint32_t u) {
        ++stamp_;
        bool repeats = false;
        for (const Link* l = adjacency.begin(u); l != adjacency.end(u); ++l) {
            Slot& before = slots_[l->prev];
            if (before.before_stamp == stamp_) {
                repeats = true;  // keep the lowest corner, as links come in corner order
            } else {
                before.before_stamp = stamp_;
                before.corner = l->corner;
            }
            Slot& after = slots_[l->next];
            repeats |= after.after_stamp == stamp_;
            after.after_stamp = stamp_;
        }
        return !repeats;
    }
    // The lowest corner at u whose triangle holds the edge x→u, or ~0u: the twin of half-edge u→x.
    uint32_t corner_after(uint32_t x) const { return slots_[x].before_stamp == stamp_ ? slots_[x].corner : ~0u; }
    // Whether u→x is an edge of one of u's triangles.
    bool follows(uint32_t x) const { return slots_[x].after_stamp == stamp_; }

private:
    struct Slot {
        uint32_t before_stamp = 0, after_stamp = 0, corner = 0;
    };
    std::vector<Slot> slots_;
    uint32_t stamp_ = 0;
};

struct Candidate {
    float cost;
    uint32_t from;
    uint32_t to;
    float geometric;  // RMS distance to u's planes at the target: the error the collapse adds
};

struct WedgePair {
    uint32_t from, to;
};

// One simplifier per thread, reused block after block: its arrays keep their storage, so a block
// costs no fresh (zero-filled) pages.
class BlockSimplifier {
public:
    SimplifyResult run(const BlockMesh& mesh, const SimplifyLimits& limits);

private:
    const Vec3& position(uint32_t point) const { return state_[point].position; }

    void init_points();
    void init_quadrics();
    void init_attributes();
    void classify();
    bool find_partners(uint32_t u, uint32_t w, std::vector<WedgePair>& pairs) const;
    float attribute_error(uint32_t from, uint32_t to) const;
    bool best_candidate(uint32_t u, Candidate& best);
    bool within(uint32_t u, uint32_t w, float distance) const;  // d∞(u, w) ≤ distance
    bool within_travel(uint32_t u, uint32_t w) const;
    bool keeps_link(uint32_t u, uint32_t w);
    bool flips(uint32_t u, uint32_t w) const;
    uint32_t collapse(uint32_t u, uint32_t w, float geometric);
    uint32_t run_pass();
    void compact_triangles();

    const BlockMesh* mesh_ = nullptr;
    SimplifyLimits limits_;
    std::vector<uint32_t> wedges_;          // per corner of the live triangles: its wedge
    std::vector<uint32_t> points_;          // per corner: its point
    uint32_t attribute_count_ = 0;

    std::vector<PointState> state_;         // per point
    std::vector<Quadric> quadrics_;         // per point
    std::vector<float> moments_;            // per wedge: area, area·a[k], area·|a|²
    std::vector<float> box_;                // per point: lo xyz, hi xyz of all points merged into it
    std::vector<float> error_;              // per point
    std::vector<uint32_t> wedge_remap_;     // per wedge
    std::vector<uint32_t> collapsed_;       // points collapsed this pass
    std::vector<Candidate> best_;           // per point: its best collapse when last looked at
    Adjacency adjacency_;
    FanMarks fan_;
    std::vector<Candidate> candidates_;
    std::vector<WedgePair> pairs_;          // scratch
    uint32_t stamp_ = 0;                    // of keeps_link, in PointState::seen
    std::vector<uint32_t> cost_bits_, order_;
};

void BlockSimplifier::init_points() {
    const uint32_t points = mesh_->point_count();
    state_.resize(points);
    for (uint32_t p = 0; p < points; ++p) {
        const float* x = &mesh_->point_positions[3 * size_t(p)];
        PointState& s = state_[p];
        s = PointState{};
        s.position = {x[0], x[1], x[2]};
        s.remap = p;
        s.locked = mesh_->point_locked[p];
        s.dirty = 1;
    }
    stamp_ = 0;
}

void BlockSimplifier::init_quadrics() {
    quadrics_.assign(mesh_->point_count(), Quadric{});
    for (uint32_t t = 0; t < wedges_.size(); t += 3) {
        Vec3 p0 = position(points_[t]), p1 = position(points_[t + 1]), p2 = position(points_[t + 2]);
        Vec3 n = cross(p1 - p0, p2 - p0);
        float twice_area = length(n);
        if (twice_area == 0) continue;
        n = n * (1.0f / twice_area);
        for (int c = 0; c < 3; ++c) quadrics_[points_[t + c]].add_plane(n, -dot(n, p0), 0.5f * twice_area);
    }
    // Boundary and seam edges: a plane through the edge, perpendicular to its face, so collapses along
    // them keep the outline (and a seam's two sides keep matching). Both endpoints of such an edge are
    // border, seam or locked points; an edge with a manifold end is neither.
    for (uint32_t a = 0; a < mesh_->point_count(); ++a) {
        if (state_[a].kind == Kind::manifold) continue;
        fan_.mark(adjacency_, a);
        for (const Link* l = adjacency_.begin(a); l != adjacency_.end(a); ++l) {
            uint32_t b = l->next;
            if (state_[b].kind == Kind::manifold) continue;
            uint32_t twin = fan_.corner_after(b);  // a's corner in the triangle holding b→a
            float weight = kBoundaryWeight;
            if (twin != ~0u) {
                bool seam = wedges_[l->corner] != wedges_[twin] || wedges_[next_corner(l->corner)] != wedges_[prev_corner(twin)];
                if (!seam) continue;
                weight = kSeamWeight;
            }
            Vec3 pa = position(a), pb = position(b), pc = position(l->prev);
            Vec3 edge = pb - pa;
            Vec3 n = cross(edge, cross(edge, pc - pa));
            float len = length(n);
            if (len == 0) continue;
            n = n * (1.0f / len);
            float w = weight * dot(edge, edge);
            quadrics_[a].add_plane(n, -dot(n, pa), w);
            quadrics_[b].add_plane(n, -dot(n, pa), w);
        }
    }
}

void BlockSimplifier::init_attributes() {
    const uint32_t stride = attribute_count_ + 2;
    moments_.assign(size_t(mesh_->wedge_count()) * stride, 0.0f);
    if (attribute_count_ == 0) return;
    for (uint32_t t = 0; t < wedges_.size(); t += 3) {
        Vec3 p0 = position(points_[t]), p1 = position(points_[t + 1]), p2 = position(points_[t + 2]);
        float area = length(cross(p1 - p0, p2 - p0)) * (0.5f / 3.0f);
        for (int c = 0; c < 3; ++c) {
            uint32_t w = wedges_[t + c];
            const float* a = &mesh_->wedge_attributes[size_t(w) * attribute_count_];
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
    const float* a = &mesh_->wedge_attributes[size_t(to) * attribute_count_];
    float e = m[1 + attribute_count_];
    for (uint32_t k = 0; k < attribute_count_; ++k) e += a[k] * (m[0] * a[k] - 2 * m[1 + k]);
    return e > 0 ? e : 0;
}

// Kinds are decided once, on the block as given: collapses that pass the link and boundary rules keep
// interior points interior and boundary points on the boundary. Edge u→x has a twin x→u exactly when x
// also precedes u in one of u's triangles, so u's own corners tell everything. A point whose
// triangles do not form one fan (two surfaces touching at it) is locked.
void BlockSimplifier::classify() {
    for (uint32_t u = 0; u < mesh_->point_count(); ++u) {
        const Link* first = adjacency_.begin(u);
        if (first == adjacency_.end(u)) continue;
        PointState& s = state_[u];
        s.single_wedge = 1;
        s.wedge = wedges_[first->corner];
        for (const Link* l = first; l != adjacency_.end(u); ++l)
            if (wedges_[l->corner] != s.wedge) s.single_wedge = 0;
        bool complex = !fan_.mark(adjacency_, u);
        int out_open = 0, in_open = 0;
        for (const Link* l = first; l != adjacency_.end(u); ++l) {
            out_open += fan_.corner_after(l->next) == ~0u;
            in_open += !fan_.follows(l->prev);
        }
        if (!complex && out_open == 0) {
            // Walk the fan: each triangle leads to the one across its edge (u, next).
            const size_t valence = size_t(adjacency_.end(u) - first);
            size_t steps = 0;
            uint32_t c = first->corner;
            do {
                c = fan_.corner_after(points_[next_corner(c)]);
                ++steps;
            } while (c != ~0u && c != first->corner && steps <= valence);
            complex = c != first->corner || steps != valence;
        }
        if (s.locked || complex || out_open > 1 || out_open != in_open) s.kind = Kind::locked;
        else if (out_open == 1) s.kind = Kind::border;
        else if (!s.single_wedge) s.kind = Kind::seam;
    }
}

// Pairs each wedge of u with the wedge of w across a shared triangle edge; false if one has none or two.
bool BlockSimplifier::find_partners(uint32_t u, uint32_t w, std::vector<WedgePair>& pairs) const {
    pairs.clear();
    const PointState &su = state_[u], &sw = state_[w];
    if (su.single_wedge && sw.single_wedge) {
        // One pair says it all, if the two share a triangle edge at all.
        for (const Link* l = adjacency_.begin(u); l != adjacency_.end(u); ++l)
            if (l->next == w || l->prev == w) {
                pairs.push_back({su.wedge, sw.wedge});
                return true;
            }
        return false;
    }
    for (const Link* l = adjacency_.begin(u); l != adjacency_.end(u); ++l) {
        uint32_t cw = corner_on(*l, w);
        if (cw == ~0u) continue;
        WedgePair pair{wedges_[l->corner], wedges_[cw]};
        bool known = false;
        for (const WedgePair& p : pairs) {
            if (p.from != pair.from) continue;
            if (p.to != pair.to) return false;
            known = true;
        }
        if (!known) pairs.push_back(pair);
    }
    if (pairs.empty()) return false;
    if (su.single_wedge) return true;
    // Every wedge of u must have found its partner.
    for (const Link* l = adjacency_.begin(u); l != adjacency_.end(u); ++l)
        if (std::none_of(pairs.begin(), pairs.end(), [&](const WedgePair& p) { return p.from == wedges_[l->corner]; }))
            return false;
    return true;
}

bool BlockSimplifier::within(uint32_t u, uint32_t w, float distance) const {
    const Vec3 d = position(u) - position(w);
    return std::fabs(d.x) <= distance && std::fabs(d.y) <= distance && std::fabs(d.z) <= distance;
}

bool BlockSimplifier::within_travel(uint32_t u, uint32_t w) const {
    const float* b = &box_[6 * u];
    const Vec3& p = position(w);
    const float t = limits_.max_travel;
    return p.x - b[0] <= t && p.y - b[1] <= t && p.z - b[2] <= t && b[3] - p.x <= t && b[4] - p.y <= t &&
           b[5] - p.z <= t;
}

// The cheapest legal collapse of u into one of its neighbours.
bool BlockSimplifier::best_candidate(uint32_t u, Candidate& best) {
    const PointState& su = state_[u];
    if (su.kind == Kind::locked) return false;
    const Quadric& q = quadrics_[u];
    const float inverse_weight = 1.0f / (q.weight > 0 ? q.weight : 1.0f);
    // A neighbour within min_fold ranks before every other: the two are one point once quantized, and
    // (the fold test skipped for it) their collapse is what undoes a pocket below the lattice step.
    bool found = false, best_near = false;
    float best_squared = 0;
    auto consider = [&](uint32_t w) {
        if (!within_travel(u, w)) return;
        const float squared = q.evaluate(position(w));
        float cost = squared;
        if (attribute_count_) {
            if (su.single_wedge && state_[w].single_wedge) {
                cost += attribute_error(su.wedge, state_[w].wedge);
            } else {
                if (!find_partners(u, w, pairs_)) return;
                for (const WedgePair& p : pairs_) cost += attribute_error(p.from, p.to);
            }
        }
        cost *= inverse_weight;
        const bool near = within(u, w, limits_.min_fold);
        if (!found || near > best_near || (near == best_near && (cost < best.cost || (cost == best.cost && w < best.to)))) {
            best = {cost, u, w, 0};
            best_squared = squared;
            best_near = near;
        }
        found = true;
    };
    if (su.kind == Kind::border) {
        // Along the boundary only: to the ends of u's two open edges.
        fan_.mark(adjacency_, u);
        for (const Link* l = adjacency_.begin(u); l != adjacency_.end(u); ++l) {
            if (fan_.corner_after(l->next) == ~0u) consider(l->next);
            if (!fan_.follows(l->prev)) consider(l->prev);
        }
    } else {
        for (const Link* l = adjacency_.begin(u); l != adjacency_.end(u); ++l) consider(l->next);
    }
    if (found) best.geometric = std::sqrt(best_squared / std::max(q.weight, 1e-30f));
    return found;
}

// Link condition, both parts: u and w may share no neighbour other than the apexes a, b of the
// triangles on edge uw, and the edge ab may not be in both links: triangles uab and wab together make
// a tetrahedron, which would fold flat into two coincident faces.
// And the block-border rule: a collapse onto a border point may not give it a new edge to another
// border point. Only such an edge can also exist in a neighbouring block, out of this block's sight;
// with the rule, every block's local check is exact and blocks never build fins between them.
bool BlockSimplifier::keeps_link(uint32_t u, uint32_t w) {
    const uint32_t mark = ++stamp_, counted = ++stamp_;
    auto now = [&](uint32_t p) { return state_[p].remap; };
    for (const Link* l = adjacency_.begin(w); l != adjacency_.end(w); ++l) {
        state_[now(l->next)].seen = mark;
        state_[now(l->prev)].seen = mark;
    }
    const bool w_locked = state_[w].locked;
    uint32_t apex[2] = {~0u, ~0u};
    int apexes = 0, shared = 0;
    for (const Link* l = adjacency_.begin(u); l != adjacency_.end(u); ++l) {
        uint32_t next = now(l->next), prev = now(l->prev);
        if (next == w || prev == w) {
            if (apexes < 2) apex[apexes] = next == w ? prev : next;
            ++apexes;
        }
        for (uint32_t p : {next, prev}) {
            PointState& sp = state_[p];
            if (p == w || sp.seen == counted) continue;
            if (sp.seen == mark) {
                sp.seen = counted;
                ++shared;
            } else if (w_locked && sp.locked) {
                return false;
            }
        }
    }
    if (shared != apexes) return false;
    if (apexes != 2) return true;
    auto spans_apexes = [&](uint32_t x) {
        for (const Link* l = adjacency_.begin(x); l != adjacency_.end(x); ++l) {
            uint32_t next = now(l->next), prev = now(l->prev);
            if ((next == apex[0] && prev == apex[1]) || (next == apex[1] && prev == apex[0])) return true;
        }
        return false;
    };
    return !(spans_apexes(u) && spans_apexes(w));
}

// Would moving u onto w turn any of u's remaining triangles over (or flatten it to nothing)?
bool BlockSimplifier::flips(uint32_t u, uint32_t w) const {
    const Vec3 from = position(u), to = position(w);
    for (const Link* l = adjacency_.begin(u); l != adjacency_.end(u); ++l) {
        if (l->next == w || l->prev == w) continue;  // collapses away
        Vec3 b = position(state_[l->next].remap);
        Vec3 d = position(state_[l->prev].remap);
        Vec3 before = cross(b - from, d - from);
        Vec3 after = cross(b - to, d - to);
        float cosine = dot(before, after);
        float scale = length(before) * length(after);
        if (scale == 0 || cosine <= kMinNormalCosine * scale) return true;
    }
    return false;
}

// Moves u onto w; returns how many triangles it removes.
uint32_t BlockSimplifier::collapse(uint32_t u, uint32_t w, float geometric) {
    const uint32_t stride = attribute_count_ + 2;
    for (const WedgePair& p : pairs_) {
        wedge_remap_[p.from] = p.to;
        if (attribute_count_)
            for (uint32_t k = 0; k < stride; ++k) moments_[size_t(p.to) * stride + k] += moments_[size_t(p.from) * stride + k];
    }
    quadrics_[w].add(quadrics_[u]);
    for (int k = 0; k < 3; ++k) {
        box_[6 * w + k] = std::min(box_[6 * w + k], box_[6 * u + k]);
        box_[6 * w + 3 + k] = std::max(box_[6 * w + 3 + k], box_[6 * u + 3 + k]);
    }
    error_[w] = std::max({error_[w], error_[u], geometric});
    state_[u].remap = w;
    collapsed_.push_back(u);
    state_[w].dirty = 1;
    uint32_t removed = 0;
    for (const Link* l = adjacency_.begin(u); l != adjacency_.end(u); ++l) {
        state_[l->next].dirty = state_[l->prev].dirty = 1;
        removed += l->next == w || l->prev == w;
    }
    return removed;
}

uint32_t BlockSimplifier::run_pass() {
    const uint32_t points = mesh_->point_count();
    // A point's best collapse depends on its quadric, box and neighbours, and its neighbours'
    // positions: only collapse targets and neighbours of collapsed points need a new look. Ties break
    // by target id, so a reused candidate is exactly what a new look would find.
    candidates_.clear();
    for (uint32_t u = 0; u < points; ++u) {
        PointState& s = state_[u];
        if (adjacency_.offsets[u] == adjacency_.offsets[u + 1]) continue;
        if (s.dirty) {
            s.has_best = best_candidate(u, best_[u]);
            s.dirty = 0;
        }
        if (s.has_best) candidates_.push_back(best_[u]);
    }
    // Costs are non-negative floats, whose bits sort like them; candidates come in point order, so
    // the stable sort breaks ties by point.
    cost_bits_.resize(candidates_.size());
    order_.resize(candidates_.size());
    for (size_t i = 0; i < candidates_.size(); ++i) {
        std::memcpy(&cost_bits_[i], &candidates_[i].cost, 4);
        order_[i] = uint32_t(i);
    }
    radix_sort_ids(cost_bits_, order_, 32);

    // Each collapse locks its two points for the pass, so many candidates get skipped; allow the pass
    // somewhat more error than the cheapest goal-many collapses would need (as meshoptimizer does).
    // Candidates that fail a test do not count towards those goal-many: cheap ones that keep failing
    // (a fold, a pinch) would otherwise set the bound and starve the pass. The bound applies once a
    // tenth of the goal is done.
    const uint32_t live = uint32_t(wedges_.size() / 3);
    const uint32_t goal = live > limits_.target_triangles ? live - limits_.target_triangles : 0;
    size_t bound_index = goal / 2;
    auto bound_at = [&](size_t i) { return i < order_.size() ? 1.5f * candidates_[order_[i]].cost : 1e30f; };
    float cost_bound = bound_at(bound_index);

    for (PointState& s : state_) s.pass_locked = 0;
    uint32_t removed = 0;
    for (uint32_t index : order_) {
        const Candidate& c = candidates_[index];
        if (removed >= goal) break;
        if (c.cost > cost_bound && removed > goal / 10) break;
        if (state_[c.from].pass_locked || state_[c.to].pass_locked) continue;
        if (c.geometric > limits_.max_error || !keeps_link(c.from, c.to) ||
            (!within(c.from, c.to, limits_.min_fold) && flips(c.from, c.to)) || !find_partners(c.from, c.to, pairs_)) {
            cost_bound = bound_at(++bound_index);
            continue;
        }
        removed += collapse(c.from, c.to, c.geometric);
        state_[c.from].pass_locked = state_[c.to].pass_locked = 1;
    }
    if (removed) compact_triangles();
    // Every remap is the identity again for the next pass: only collapsed points were changed.
    for (uint32_t u : collapsed_) state_[u].remap = u;
    collapsed_.clear();
    return removed;
}

void BlockSimplifier::compact_triangles() {
    size_t out = 0;
    for (size_t t = 0; t < wedges_.size(); t += 3) {
        uint32_t pa = state_[points_[t]].remap, pb = state_[points_[t + 1]].remap, pc = state_[points_[t + 2]].remap;
        if (pa == pb || pb == pc || pa == pc) continue;
        for (int c = 0; c < 3; ++c) wedges_[out + c] = wedge_remap_[wedges_[t + c]];
        points_[out] = pa, points_[out + 1] = pb, points_[out + 2] = pc;
        out += 3;
    }
    wedges_.resize(out);
    points_.resize(out);
    adjacency_.build(points_, mesh_->point_count());
}

SimplifyResult BlockSimplifier::run(const BlockMesh& mesh, const SimplifyLimits& limits) {
    mesh_ = &mesh;
    limits_ = limits;
    attribute_count_ = mesh.attribute_count;
    wedges_ = mesh.triangles;
    points_.resize(wedges_.size());
    for (size_t i = 0; i < wedges_.size(); ++i) points_[i] = mesh.wedge_point[wedges_[i]];

    const uint32_t points = mesh.point_count();
    init_points();
    fan_.reset(points);
    adjacency_.build(points_, points);
    classify();
    init_quadrics();
    init_attributes();
    box_.resize(6 * size_t(points));
    for (uint32_t p = 0; p < points; ++p)
        for (int k = 0; k < 3; ++k) box_[6 * p + k] = box_[6 * p + 3 + k] = mesh.point_positions[3 * p + k];
    error_.assign(points, 0.0f);
    wedge_remap_.resize(mesh.wedge_count());
    std::iota(wedge_remap_.begin(), wedge_remap_.end(), 0u);
    best_.resize(points);

    while (wedges_.size() / 3 > limits_.target_triangles && run_pass() > 0) {
    }

    // Compose collapse chains: v → u in one pass and u → w in a later one make P(v) = w.
    SimplifyResult result;
    result.wedge_remap = wedge_remap_;
    for (uint32_t& target : result.wedge_remap)
        while (result.wedge_remap[target] != target) target = result.wedge_remap[target];
    result.point_error = error_;
    result.triangles_left = uint32_t(wedges_.size() / 3);
    return result;
}

}  // namespace

SimplifyResult simplify_block(const BlockMesh& mesh, const SimplifyLimits& limits) {
    thread_local BlockSimplifier simplifier;
    return simplifier.run(mesh, limits);
}

}  // namespace strata
