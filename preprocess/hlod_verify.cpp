#include "preprocess/hlod_verify.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <tuple>
#include <unordered_map>

#include "preprocess/embedding_file.h"
#include "preprocess/error_bound.h"
#include "preprocess/cube_textures.h"
#include "preprocess/terrain_heights.h"

namespace strata {
namespace {

std::string fmt(double x) {
    std::ostringstream s;
    s.precision(6);
    s << x;
    return s.str();
}

uint32_t octant_of(const HlodNode& n) { return (n.i & 1) | (n.j & 1) << 1 | (n.k & 1) << 2; }

// (level, i, j, k) packed in 64 bits: 4 bits of level, 15 bits per index (levels go to 15).
uint64_t cube_key(uint32_t level, uint32_t i, uint32_t j, uint32_t k) {
    return uint64_t(level) << 60 | uint64_t(k) << 30 | uint64_t(j) << 15 | i;
}
uint64_t parent_key(const HlodNode& n) { return cube_key(n.level - 1, n.i / 2, n.j / 2, n.k / 2); }

// A vertex as its bytes: position ints, normal, colour, UV. Parent copies are compared this way.
std::string vertex_bytes(const VertexArrays& a, uint32_t v) {
    std::string key;
    auto add = [&](const void* p, size_t n) { key.append(static_cast<const char*>(p), n); };
    add(&a.positions[3 * size_t(v)], 6);
    add(&a.normals[2 * size_t(v)], 4);
    if (!a.colors.empty()) add(&a.colors[4 * size_t(v)], 4);
    if (!a.uvs.empty()) add(&a.uvs[2 * size_t(v)], 8);
    return key;
}

using Triangle = std::array<uint32_t, 3>;

// Rotates a triangle so its smallest index comes first, keeping its orientation.
Triangle canonical(Triangle t) {
    while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};
    return t;
}

bool same_position(const CubeData& c, uint32_t a, uint32_t b) {
    return std::memcmp(&c.vertices.positions[3 * size_t(a)], &c.vertices.positions[3 * size_t(b)], 6) == 0;
}

using LatticePoint = std::array<int32_t, 3>;

// splitmix64's finalizer: a bijection of 64-bit words in which every input bit flips every output bit
// with probability about one half.
uint64_t mix(uint64_t x) {
    x ^= x >> 30, x *= 0xbf58476d1ce4e5b9u;
    x ^= x >> 27, x *= 0x94d049bb133111ebu;
    return x ^ (x >> 31);
}

uint64_t edge_hash(const LatticePoint& from, const LatticePoint& to) {
    uint64_t h = 0x9e3779b97f4a7c15u;
    for (int32_t c : from) h = mix(h ^ uint32_t(c));
    for (int32_t c : to) h = mix(h ^ uint32_t(c));
    return h;
}

// Whether one level is closed, in memory that does not grow with the level: the sum (mod 2^64) of a
// 64-bit hash of every directed edge, minus that of every reversed edge, is zero exactly when each
// directed edge is matched by as many reverse edges, up to a collision of probability about 2^-64.
// Fins and doubled faces are found within each cube (an exact check needs every edge at once).
struct Closure {
    uint64_t edge_balance = 0;
    std::string defect;  // a local defect ("has an edge with two faces the same way"), or empty

    bool closed() const { return edge_balance == 0 && defect.empty(); }
    std::string what() const { return defect.empty() ? "has a boundary edge" : defect; }
};

// A locked boundary (MODL flag bit 3), in memory that does not grow with the level: the XOR of a 64-bit
// hash of every undirected edge, its ends identified by their decoded floats, is that of the edges an
// odd number of triangles use (the boundary, on a surface), since an edge used twice cancels. Every level
// must give level L's: the same edges, each end decoded to the same floats. Triangles with two corners
// at one decoded position are skipped. A level's vertices that decode to one float are one point, at
// every level alike for the boundary's, and merging a point all of whose edges are used an even number
// of times leaves every count's parity as it was: a check without false alarms.
uint64_t open_edges_hash(const HlodHeader& h, const HlodNode& n, const CubeData& cube) {
    const uint32_t cell[3] = {n.i, n.j, n.k};
    std::vector<LatticePoint> point(cube.vertex_count());  // a position's float bits, −0 as +0
    for (uint32_t v = 0; v < cube.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) {
            const float x = decode_coordinate(h, a, n.level, cell[a], cube.vertices.positions[3 * v + a]) + 0.0f;
            std::memcpy(&point[v][a], &x, 4);
        }
    uint64_t hash = 0;
    for (size_t t = 0; t < cube.indices.size(); t += 3) {
        const LatticePoint* f[3] = {&point[cube.indices[t]], &point[cube.indices[t + 1]], &point[cube.indices[t + 2]]};
        if (*f[0] == *f[1] || *f[1] == *f[2] || *f[0] == *f[2]) continue;
        for (int e = 0; e < 3; ++e) {
            const LatticePoint &a = *f[e], &b = *f[(e + 1) % 3];
            hash ^= a < b ? edge_hash(a, b) : edge_hash(b, a);
        }
    }
    return hash;
}

// The cube whose children are being checked, decoded once for all its children.
struct ParentCube {
    const HlodNode* node = nullptr;
    CubeData data;
    // A vertex's bytes → the first vertex with them: triangles are compared by vertex, not by index.
    std::unordered_map<std::string, uint32_t> lookup;
};

class Verifier {
public:
    Verifier(const HlodFile& file, const Progress& progress)
        : file_(file), h_(file.header()), name_(file.path().string()), progress_(progress) {}

    VerifyReport run();

private:
    [[noreturn]] void fail(const std::string& what) const { throw VerifyError(name_ + ": " + what); }
    // Positions decode in float (as the renderer does): allow a few ulps of the model's coordinates.
    double float_slack() const {
        double extent = std::max({std::fabs(h_.origin[0]), std::fabs(h_.origin[1]), std::fabs(h_.origin[2])}) + h_.root_size;
        return 4 * extent * 0x1p-23;
    }
    void check_node_table();
    void check_payload_layout();
    std::vector<const HlodNode*> walk_order(uint32_t level) const;
    const ParentCube& parent_of(const HlodNode& n);
    void check_cube_bounds(const HlodNode& n, const CubeData& cube);
    void check_texture(const HlodNode& n, const CubeData& cube);
    void check_parent_index(const HlodNode& n, const CubeData& cube, uint32_t v, uint32_t parent_vertices) const;
    void check_root(const HlodNode& n, const CubeData& cube);
    void check_child_groups(const HlodNode& n, const CubeData& cube);
    void check_against_parent(const HlodNode& n, const CubeData& cube, const ParentCube& parent);
    void add_to_closure(const HlodNode& n, const CubeData& cube, Closure& closure);

    const HlodFile& file_;
    const HlodHeader& h_;
    std::string name_;
    const Progress& progress_;
    VerifyReport report_;
    std::vector<std::vector<const HlodNode*>> levels_;  // the node table by level
    std::unordered_map<uint64_t, const HlodNode*> cubes_;  // by cube_key
    ParentCube parent_;
    std::unique_ptr<const CubeTextures> textures_;  // a textured model's (section TXTR)
};

// Everything the node table alone shows: errors, no cube twice, every level present, the root, a
// parent for every cube, and no parent more exact than its children.
void Verifier::check_node_table() {
    levels_.assign(h_.max_level + 1, {});
    for (const HlodNode& n : file_.nodes()) {
        if (!std::isfinite(n.error) || n.error < 0) fail(describe_cube(n) + " has error " + fmt(n.error));
        const double relative = n.error / h_.cube_size(n.level);
        if (relative > h_.error_q * (1 + 1e-5) + 1e-7)
            fail(describe_cube(n) + " has error " + fmt(relative) + "·s_l, above the header's ε_q " + fmt(h_.error_q));
        if (!(h_.flags & kErrorsAreBounds)) {
            if (n.level == h_.max_level && n.error != 0) fail(describe_cube(n) + " at full resolution has nonzero error");
        } else if (n.error < build::lattice_rounding(h_.root_size, h_.cube_size(n.level)) * (1 - 1e-6)) {
            fail(describe_cube(n) + " has error " + fmt(n.error) + ", below its lattice's rounding: not a bound");
        }
        if (!cubes_.emplace(cube_key(n.level, n.i, n.j, n.k), &n).second) fail(describe_cube(n) + " appears twice in the node table");
        levels_[n.level].push_back(&n);
    }
    for (uint32_t l = 0; l <= h_.max_level; ++l)
        if (levels_[l].empty()) fail("level " + std::to_string(l) + " has no cubes");
    if (levels_[0].size() != 1) fail("level 0 must be exactly the root cube");
    for (const HlodNode& n : file_.nodes()) {
        if (n.level == 0) continue;
        auto parent = cubes_.find(parent_key(n));
        if (parent == cubes_.end()) fail(describe_cube(n) + " has no parent cube");
        if (parent->second->error < n.error)
            fail(describe_cube(*parent->second) + " has error " + fmt(parent->second->error) + ", less than its child " +
                 describe_cube(n) + "'s " + fmt(n.error));
    }
}

// FORMAT.md §4: levels in order, each from a 4 KiB boundary, no payload overlapping another.
void Verifier::check_payload_layout() {
    std::vector<const HlodNode*> order;
    for (const HlodNode& n : file_.nodes()) order.push_back(&n);
    std::sort(order.begin(), order.end(), [](auto* a, auto* b) { return a->offset < b->offset; });
    for (size_t p = 0; p < order.size(); ++p) {
        const HlodNode& n = *order[p];
        const HlodNode* previous = p ? order[p - 1] : nullptr;
        if (previous && previous->offset + previous->size > n.offset)
            fail(describe_cube(n) + "'s payload overlaps that of " + describe_cube(*previous));
        if (previous && previous->level > n.level)
            fail(describe_cube(n) + "'s payload lies after a finer level's (coarse levels come first)");
        if ((!previous || previous->level != n.level) && n.offset % 4096 != 0)
            fail("level " + std::to_string(n.level) + "'s payloads do not start on a 4 KiB boundary");
    }
}

// A level's cubes sorted by (parent, octant): siblings come together, so one decoded parent serves them
// all, and the parents come in key order, as do their payloads in the file.
std::vector<const HlodNode*> Verifier::walk_order(uint32_t level) const {
    std::vector<const HlodNode*> order = levels_[level];
    auto key = [](const HlodNode* n) { return std::tuple(n->k / 2, n->j / 2, n->i / 2, octant_of(*n)); };
    std::sort(order.begin(), order.end(), [&](auto* a, auto* b) { return key(a) < key(b); });
    return order;
}

const ParentCube& Verifier::parent_of(const HlodNode& n) {
    if (parent_.node && parent_key(n) == cube_key(parent_.node->level, parent_.node->i, parent_.node->j, parent_.node->k))
        return parent_;
    parent_.node = cubes_.at(parent_key(n));  // the node table check found every parent
    parent_.data = file_.read_cube(*parent_.node);
    parent_.lookup.clear();
    for (uint32_t v = parent_.data.vertex_count(); v-- > 0;) parent_.lookup[vertex_bytes(parent_.data.vertices, v)] = v;
    return parent_;
}

// No vertex farther than σ0·s_l from its cell (give or take the lattice step).
void Verifier::check_cube_bounds(const HlodNode& n, const CubeData& cube) {
    const double s = h_.cube_size(n.level), tolerance = h_.sigma0 * s + h_.lattice_step(n.level) + float_slack();
    const uint32_t cell[3] = {n.i, n.j, n.k};
    for (uint32_t v = 0; v < cube.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) {
            double x = decode_coordinate(h_, a, n.level, cell[a], cube.vertices.positions[3 * v + a]);
            double lo = h_.origin[a] + cell[a] * s, hi = lo + s;
            double d = std::max({0.0, lo - x, x - hi});
            if (d > tolerance)
                fail(describe_cube(n) + ": vertex " + std::to_string(v) + " lies " + fmt(d) +
                     " from its cell, more than σ0·s_l = " + fmt(h_.sigma0 * s));
        }
}

// A textured model's cube: its texture decodes, and (planar mapping) every vertex lies on it.
void Verifier::check_texture(const HlodNode& n, const CubeData& cube) {
    textures_->read(uint64_t(&n - file_.nodes().data()), n);
    const float margin = textures_->layout().margin;
    const uint32_t cell[2] = {n.i, n.j};
    const double s = h_.cube_size(n.level), reach = margin * s + h_.lattice_step(n.level) / 2 + float_slack();
    for (uint32_t v = 0; v < cube.vertex_count(); ++v)
        for (int a = 0; a < 2; ++a) {
            const double x = decode_coordinate(h_, a, n.level, cell[a], cube.vertices.positions[3 * v + size_t(a)]);
            const double lo = h_.origin[a] + cell[a] * s, d = std::max({0.0, lo - x, x - lo - s});
            if (d > reach)
                fail(describe_cube(n) + ": vertex " + std::to_string(v) + " lies " + fmt(d) + " beyond its cell, off its texture (margin " +
                     fmt(margin * s) + ")");
        }
}

// P(v) names a vertex of the parent cube (of the cube itself at level 0).
void Verifier::check_parent_index(const HlodNode& n, const CubeData& cube, uint32_t v, uint32_t parent_vertices) const {
    if (cube.parent_vertex[v] >= parent_vertices)
        fail(describe_cube(n) + ": vertex " + std::to_string(v) + "'s parent " + std::to_string(cube.parent_vertex[v]) +
             " lies past the parent cube's " + std::to_string(parent_vertices) + " vertices");
}

// At level 0 every vertex is its own parent.
void Verifier::check_root(const HlodNode& n, const CubeData& cube) {
    for (uint32_t v = 0; v < cube.vertex_count(); ++v) {
        check_parent_index(n, cube, v, cube.vertex_count());
        if (vertex_bytes(cube.vertices, v) != vertex_bytes(cube.vertices, cube.parent_vertex[v]))
            fail(describe_cube(n) + ": vertex " + std::to_string(v) + " is not its own parent at level 0");
    }
}

// Every triangle of a cube came from a child that exists (FORMAT.md §8).
void Verifier::check_child_groups(const HlodNode& n, const CubeData& cube) {
    if (n.level == h_.max_level) return;
    for (uint32_t o = 0; o < 8; ++o)
        if (cube.child_triangle_counts[o] &&
            !cubes_.count(cube_key(n.level + 1, 2 * n.i + (o & 1), 2 * n.j + (o >> 1 & 1), 2 * n.k + (o >> 2 & 1))))
            fail(describe_cube(n) + " has triangles from child octant " + std::to_string(o) + ", which has no cube");
}

void Verifier::check_against_parent(const HlodNode& n, const CubeData& cube, const ParentCube& parent) {
    const uint32_t l = n.level;
    const HlodNode& pn = *parent.node;
    // P(v): a vertex of the parent cube, within σ0·s_{l+1} of v.
    const double bound = h_.sigma0 * h_.cube_size(l + 1) + h_.lattice_step(l) + h_.lattice_step(l - 1) + 2 * float_slack();
    const uint32_t cell[3] = {n.i, n.j, n.k}, parent_cell[3] = {pn.i, pn.j, pn.k};
    const CubeData& p = parent.data;
    auto canonical_parent_index = [&](uint32_t v) { return parent.lookup.at(vertex_bytes(p.vertices, v)); };
    std::vector<uint32_t> parent_vertex(cube.vertex_count());
    for (uint32_t v = 0; v < cube.vertex_count(); ++v) {
        check_parent_index(n, cube, v, p.vertex_count());
        const uint32_t pv = cube.parent_vertex[v];
        parent_vertex[v] = canonical_parent_index(pv);
        double d = 0;
        for (int a = 0; a < 3; ++a) {
            float x = decode_coordinate(h_, a, l, cell[a], cube.vertices.positions[3 * v + a]);
            float px = decode_coordinate(h_, a, l - 1, parent_cell[a], p.vertices.positions[3 * size_t(pv) + a]);
            d = std::max(d, std::fabs(double(x) - double(px)));
        }
        if (d > bound)
            fail(describe_cube(n) + ": vertex " + std::to_string(v) + " lies " + fmt(d) +
                 " from its parent, more than σ0·s_{l+1} = " + fmt(h_.sigma0 * h_.cube_size(l + 1)));
    }

    // P(T(C)) ≃ the parent's triangles from this child, up to degenerates and cyclic rotation. Both
    // sides are one cube's worth, so sorting them is bounded by the cube.
    auto degenerate = [&](const Triangle& t) {
        return same_position(p, t[0], t[1]) || same_position(p, t[1], t[2]) || same_position(p, t[0], t[2]);
    };
    std::vector<Triangle> mapped, expected;
    for (size_t t = 0; t < cube.indices.size(); t += 3) {
        Triangle tri{parent_vertex[cube.indices[t]], parent_vertex[cube.indices[t + 1]], parent_vertex[cube.indices[t + 2]]};
        if (!degenerate(tri)) mapped.push_back(canonical(tri));
    }
    const uint32_t octant = octant_of(n);
    size_t first = 0;
    for (uint32_t o = 0; o < octant; ++o) first += p.child_triangle_counts[o];
    for (size_t t = first; t < first + p.child_triangle_counts[octant]; ++t) {
        Triangle tri{canonical_parent_index(p.indices[3 * t]), canonical_parent_index(p.indices[3 * t + 1]),
                     canonical_parent_index(p.indices[3 * t + 2])};
        if (!degenerate(tri)) expected.push_back(canonical(tri));
    }
    std::sort(mapped.begin(), mapped.end());
    std::sort(expected.begin(), expected.end());
    if (mapped != expected)
        fail(describe_cube(n) + ": its " + std::to_string(mapped.size()) + " triangles mapped by P differ from the " +
             std::to_string(expected.size()) + " of its part of " + describe_cube(pn));
}

// Positions are compared on the level's global lattice, so a vertex shared by two cubes is one vertex;
// triangles with two corners at one position are skipped.
void Verifier::add_to_closure(const HlodNode& n, const CubeData& cube, Closure& closure) {
    const uint32_t cell[3] = {n.i, n.j, n.k};
    std::vector<LatticePoint> q(cube.vertex_count());
    for (uint32_t v = 0; v < cube.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a)
            q[v][a] = int32_t(cube.vertices.positions[3 * v + a]) + int32_t(cell[a] << kLatticeBits) - kLatticeBias;
    std::vector<std::pair<LatticePoint, LatticePoint>> edges;
    std::vector<std::array<LatticePoint, 3>> faces;
    for (size_t t = 0; t < cube.indices.size(); t += 3) {
        std::array<LatticePoint, 3> f{q[cube.indices[t]], q[cube.indices[t + 1]], q[cube.indices[t + 2]]};
        if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
        for (int e = 0; e < 3; ++e) {
            const LatticePoint &from = f[e], &to = f[(e + 1) % 3];
            closure.edge_balance += edge_hash(from, to) - edge_hash(to, from);
            edges.emplace_back(from, to);
        }
        std::sort(f.begin(), f.end());
        faces.push_back(f);
    }
    if (!closure.defect.empty()) return;
    std::sort(edges.begin(), edges.end());
    std::sort(faces.begin(), faces.end());
    if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) closure.defect = "has an edge with two faces the same way";
    else if (std::adjacent_find(faces.begin(), faces.end()) != faces.end()) closure.defect = "has two faces on the same three vertices";
}

VerifyReport Verifier::run() {
    // An embedding (FORMAT.md §4.10): its section parses and fits the raster; a standing site's has no cube.
    if (file_.find_section(kEmbeddingTag)) {
        const EmbeddingRecord embedding = read_embedding(file_);
        report_.embedding = true;
        if (embedding.standing != (h_.node_count == 0))
            fail(embedding.standing ? "a standing site's embedding with cubes" : "an embedding without a skirt, though its site is not standing");
        if (embedding.standing) {
            file_.check_section(*file_.find_section("PAYL"));
            return report_;
        }
    }
    if (h_.node_count == 0) fail("no cubes");
    check_node_table();
    check_payload_layout();
    const HlodSection* textures = file_.find_section(kTexturesTag);
    if (textures)
        textures_ = std::make_unique<const CubeTextures>(std::shared_ptr<const HlodFile>(std::shared_ptr<const void>(), &file_), *textures,
                                                         file_.nodes().size());
    // Level by level, coarse to fine, one cube decoded at a time besides the parent its siblings share.
    std::vector<Closure> closures(h_.max_level + 1);
    const bool locked = h_.flags & kLockedBoundary;
    std::vector<uint64_t> open_edges(h_.max_level + 1, 0);
    for (uint32_t l = 0; l <= h_.max_level; ++l) {
        progress_("verify", l, h_.max_level + 1, "level");
        for (const HlodNode* n : walk_order(l)) {
            progress_.check();
            const CubeData cube = file_.read_cube(*n);
            report_.cubes++, report_.vertices += n->vertex_count, report_.triangles += n->triangle_count;
            check_cube_bounds(*n, cube);
            if (textures_) check_texture(*n, cube);
            if (l == 0) check_root(*n, cube);
            else check_against_parent(*n, cube, parent_of(*n));
            check_child_groups(*n, cube);
            add_to_closure(*n, cube, closures[l]);
            if (locked) open_edges[l] ^= open_edges_hash(h_, *n, cube);
        }
    }
    // If level L is closed, the input was: every level must be closed too.
    report_.watertight = closures[h_.max_level].closed();
    for (uint32_t l = 0; report_.watertight && l < h_.max_level; ++l)
        if (!closures[l].closed())
            fail("level " + std::to_string(l) + " " + closures[l].what() + ", though the full-resolution level is closed");
    for (uint32_t l = 0; locked && l < h_.max_level; ++l)
        if (open_edges[l] != open_edges[h_.max_level])
            fail("level " + std::to_string(l) + "'s open boundary is not the full-resolution level's (other edges, or "
                 "vertices decoding to other floats), though the model says its boundary is locked");
    report_.boundary_locked = locked;
    // Payloads were checked one by one; this also covers the padding between levels.
    file_.check_section(*file_.find_section("PAYL"));
    // A terrain's heights: the whole section's checksum, and every block decodes.
    if (const HlodSection* heights = file_.find_section(kHeightsTag)) {
        file_.check_section(*heights);
        TerrainHeights(std::shared_ptr<const HlodFile>(std::shared_ptr<const void>(), &file_), *heights).check_all();
    }
    if (textures) file_.check_section(*textures);  // each texture was checked with its cube
    progress_("verify", h_.max_level + 1, h_.max_level + 1, "level");
    return report_;
}

}  // namespace

VerifyReport verify_hlod(const HlodFile& file, const Progress& progress) {
    return Verifier(file, progress).run();
}

}  // namespace strata
