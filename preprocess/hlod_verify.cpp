#include "preprocess/hlod_verify.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <unordered_map>

namespace strata {
namespace {

using CubeKey = std::array<uint32_t, 3>;

struct LevelData {
    uint32_t level = 0;
    std::vector<const HlodNode*> nodes;
    std::vector<CubeData> cubes;
    std::map<CubeKey, size_t> index;
};

std::string fmt(double x) {
    std::ostringstream s;
    s.precision(6);
    s << x;
    return s.str();
}

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
    LevelData load_level(uint32_t level);
    void resolve_level(LevelData& level, const LevelData* parents);
    void check_cube_bounds(const LevelData& level, size_t c);
    void check_root(const CubeData& cube, const HlodNode& node);
    void check_against_parent(const LevelData& level, size_t c, const LevelData& parents);
    bool check_watertight(const LevelData& level, bool required);
    void check_parent_groups(const LevelData& children, const LevelData& parents);

    const HlodFile& file_;
    const HlodHeader& h_;
    std::string name_;
    const Progress& progress_;
    VerifyReport report_;
    // Per parent cube: its vertices' bytes → first index with those bytes.
    std::vector<std::unordered_map<std::string, uint32_t>> parent_lookup_;
};

LevelData Verifier::load_level(uint32_t level) {
    LevelData data;
    data.level = level;
    for (const HlodNode& n : file_.nodes())
        if (n.level == level) {
            if (!data.index.emplace(CubeKey{n.i, n.j, n.k}, data.nodes.size()).second)
                fail(describe_cube(n) + " appears twice in the node table");
            data.nodes.push_back(&n);
        }
    if (data.nodes.empty()) fail("level " + std::to_string(level) + " has no cubes");
    for (const HlodNode* n : data.nodes) {
        progress_.check();
        data.cubes.push_back(file_.read_cube(*n));
        report_.cubes++, report_.vertices += n->vertex_count, report_.triangles += n->triangle_count;
        if (!std::isfinite(n->error) || n->error < 0) fail(describe_cube(*n) + " has error " + fmt(n->error));
        double relative = n->error / h_.cube_size(level);
        if (relative > h_.error_q * (1 + 1e-5) + 1e-7)
            fail(describe_cube(*n) + " has error " + fmt(relative) + "·s_l, above the header's ε_q " + fmt(h_.error_q));
        if (level == h_.max_level && n->error != 0) fail(describe_cube(*n) + " at full resolution has nonzero error");
    }
    return data;
}

// Each vertex's parent, copied from the parent cube (from the cube itself at level 0).
void Verifier::resolve_level(LevelData& level, const LevelData* parents) {
    for (size_t c = 0; c < level.cubes.size(); ++c) {
        const HlodNode& n = *level.nodes[c];
        const CubeData* parent = &level.cubes[c];
        if (parents) {
            auto it = parents->index.find(CubeKey{n.i / 2, n.j / 2, n.k / 2});
            if (it == parents->index.end()) fail(describe_cube(n) + " has no parent cube");
            parent = &parents->cubes[it->second];
        }
        try {
            resolve_parents(level.cubes[c], parent->vertices, describe_cube(n));
        } catch (const std::runtime_error& e) {
            fail(e.what());
        }
    }
}

// No vertex farther than σ0·s_l from its cell (give or take the lattice step).
void Verifier::check_cube_bounds(const LevelData& level, size_t c) {
    const HlodNode& n = *level.nodes[c];
    const CubeData& cube = level.cubes[c];
    const double s = h_.cube_size(level.level), tolerance = h_.sigma0 * s + h_.lattice_step(level.level) + float_slack();
    const uint32_t cell[3] = {n.i, n.j, n.k};
    for (uint32_t v = 0; v < cube.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) {
            double x = decode_coordinate(h_, a, level.level, cell[a], cube.vertices.positions[3 * v + a]);
            double lo = h_.origin[a] + cell[a] * s, hi = lo + s;
            double d = std::max({0.0, lo - x, x - hi});
            if (d > tolerance)
                fail(describe_cube(n) + ": vertex " + std::to_string(v) + " lies " + fmt(d) +
                     " from its cell, more than σ0·s_l = " + fmt(h_.sigma0 * s));
        }
}

// At level 0 every vertex is its own parent.
void Verifier::check_root(const CubeData& cube, const HlodNode& n) {
    for (uint32_t v = 0; v < cube.vertex_count(); ++v)
        if (vertex_bytes(cube.vertices, v) != vertex_bytes(cube.parents, cube.parent_of[v]))
            fail(describe_cube(n) + ": vertex " + std::to_string(v) + " is not its own parent at level 0");
}

void Verifier::check_against_parent(const LevelData& level, size_t c, const LevelData& parents) {
    const HlodNode& n = *level.nodes[c];
    const CubeData& cube = level.cubes[c];
    const uint32_t l = level.level;
    auto it = parents.index.find(CubeKey{n.i / 2, n.j / 2, n.k / 2});
    if (it == parents.index.end()) fail(describe_cube(n) + " has no parent cube");
    const size_t p = it->second;
    const HlodNode& pn = *parents.nodes[p];
    const CubeData& parent = parents.cubes[p];
    auto& lookup = parent_lookup_[p];
    if (lookup.empty())
        for (uint32_t v = parent.vertex_count(); v-- > 0;) lookup[vertex_bytes(parent.vertices, v)] = v;

    // P(v): a vertex of the parent cube, within σ0·s_{l+1} of v.
    const double bound = h_.sigma0 * h_.cube_size(l + 1) + h_.lattice_step(l) + h_.lattice_step(l - 1) + 2 * float_slack();
    const uint32_t cell[3] = {n.i, n.j, n.k}, parent_cell[3] = {pn.i, pn.j, pn.k};
    std::vector<uint32_t> parent_of(cube.vertex_count());
    for (uint32_t v = 0; v < cube.vertex_count(); ++v) {
        const uint32_t pv = cube.parent_of[v];
        auto found = lookup.find(vertex_bytes(cube.parents, pv));
        if (found == lookup.end())
            fail(describe_cube(n) + ": the parent of vertex " + std::to_string(v) + " is not a vertex of " +
                 describe_cube(pn));
        parent_of[v] = found->second;
        double d = 0;
        for (int a = 0; a < 3; ++a) {
            float x = decode_coordinate(h_, a, l, cell[a], cube.vertices.positions[3 * v + a]);
            float px = decode_coordinate(h_, a, l - 1, parent_cell[a], cube.parents.positions[3 * size_t(pv) + a]);
            d = std::max(d, std::fabs(double(x) - double(px)));
        }
        if (d > bound)
            fail(describe_cube(n) + ": vertex " + std::to_string(v) + " lies " + fmt(d) +
                 " from its parent, more than σ0·s_{l+1} = " + fmt(h_.sigma0 * h_.cube_size(l + 1)));
    }

    // P(T(C)) ≃ the parent's triangles from this child, up to degenerates and cyclic rotation.
    auto canonical_parent_index = [&](uint32_t v) { return lookup.at(vertex_bytes(parent.vertices, v)); };
    std::vector<Triangle> mapped, expected;
    for (size_t t = 0; t < cube.indices.size(); t += 3) {
        Triangle tri{parent_of[cube.indices[t]], parent_of[cube.indices[t + 1]], parent_of[cube.indices[t + 2]]};
        if (same_position(parent, tri[0], tri[1]) || same_position(parent, tri[1], tri[2]) ||
            same_position(parent, tri[0], tri[2]))
            continue;
        mapped.push_back(canonical(tri));
    }
    const uint32_t octant = (n.i & 1) | (n.j & 1) << 1 | (n.k & 1) << 2;
    size_t first = 0;
    for (uint32_t o = 0; o < octant; ++o) first += parent.child_triangle_counts[o];
    for (size_t t = first; t < first + parent.child_triangle_counts[octant]; ++t) {
        Triangle tri{canonical_parent_index(parent.indices[3 * t]), canonical_parent_index(parent.indices[3 * t + 1]),
                     canonical_parent_index(parent.indices[3 * t + 2])};
        if (same_position(parent, tri[0], tri[1]) || same_position(parent, tri[1], tri[2]) ||
            same_position(parent, tri[0], tri[2]))
            continue;
        expected.push_back(canonical(tri));
    }
    std::sort(mapped.begin(), mapped.end());
    std::sort(expected.begin(), expected.end());
    if (mapped != expected)
        fail(describe_cube(n) + ": its " + std::to_string(mapped.size()) + " triangles mapped by P differ from the " +
             std::to_string(expected.size()) + " of its part of " + describe_cube(pn));
}

// Every triangle of a parent came from a child that exists, and no parent is more exact than its children.
void Verifier::check_parent_groups(const LevelData& children, const LevelData& parents) {
    std::vector<uint8_t> has_child(parents.cubes.size(), 0);
    for (size_t c = 0; c < children.cubes.size(); ++c) {
        const HlodNode& n = *children.nodes[c];
        size_t p = parents.index.at(CubeKey{n.i / 2, n.j / 2, n.k / 2});
        has_child[p] |= uint8_t(1u << ((n.i & 1) | (n.j & 1) << 1 | (n.k & 1) << 2));
        if (parents.nodes[p]->error < n.error)
            fail(describe_cube(*parents.nodes[p]) + " has error " + fmt(parents.nodes[p]->error) + ", less than its child " +
                 describe_cube(n) + "'s " + fmt(n.error));
    }
    for (size_t p = 0; p < parents.cubes.size(); ++p)
        for (uint32_t o = 0; o < 8; ++o)
            if (parents.cubes[p].child_triangle_counts[o] && !(has_child[p] >> o & 1))
                fail(describe_cube(*parents.nodes[p]) + " has triangles from child octant " + std::to_string(o) +
                     ", which has no cube");
}

// Closed and manifold: every edge carries exactly one face each way, and no two triangles share their
// three vertices (which would be a fin or a face folded flat onto its twin). Positions are compared
// on the global lattice, so a vertex shared by two cubes is one vertex.
bool Verifier::check_watertight(const LevelData& level, bool required) {
    struct Hash {
        size_t operator()(const std::array<int32_t, 3>& q) const {
            return size_t(q[0]) * 73856093u ^ size_t(q[1]) * 19349663u ^ size_t(q[2]) * 83492791u;
        }
    };
    std::unordered_map<std::array<int32_t, 3>, uint32_t, Hash> ids;
    std::vector<uint64_t> edges;
    std::vector<std::array<uint32_t, 3>> faces;
    for (size_t c = 0; c < level.cubes.size(); ++c) {
        const CubeData& cube = level.cubes[c];
        const HlodNode& n = *level.nodes[c];
        const uint32_t cell[3] = {n.i, n.j, n.k};
        std::vector<uint32_t> id(cube.vertex_count());
        for (uint32_t v = 0; v < cube.vertex_count(); ++v) {
            std::array<int32_t, 3> q;
            for (int a = 0; a < 3; ++a)
                q[a] = int32_t(cube.vertices.positions[3 * v + a]) + int32_t(cell[a] << kLatticeBits) - kLatticeBias;
            id[v] = ids.emplace(q, uint32_t(ids.size())).first->second;
        }
        for (size_t t = 0; t < cube.indices.size(); t += 3) {
            std::array<uint32_t, 3> f{id[cube.indices[t]], id[cube.indices[t + 1]], id[cube.indices[t + 2]]};
            if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
            for (int e = 0; e < 3; ++e) edges.push_back(uint64_t(f[e]) << 32 | f[(e + 1) % 3]);
            std::sort(f.begin(), f.end());
            faces.push_back(f);
        }
    }
    auto open = [&](const std::string& what) {
        if (required)
            fail("level " + std::to_string(level.level) + " " + what + ", though the full-resolution level is closed");
        return false;
    };
    std::sort(edges.begin(), edges.end());
    for (size_t i = 0; i < edges.size(); ++i) {
        if (i + 1 < edges.size() && edges[i + 1] == edges[i]) return open("has an edge with two faces the same way");
        uint64_t reverse = (edges[i] & 0xFFFFFFFFu) << 32 | edges[i] >> 32;
        if (!std::binary_search(edges.begin(), edges.end(), reverse)) return open("has a boundary edge");
    }
    std::sort(faces.begin(), faces.end());
    if (std::adjacent_find(faces.begin(), faces.end()) != faces.end()) return open("has two faces on the same three vertices");
    return true;
}

VerifyReport Verifier::run() {
    if (h_.node_count == 0) fail("no cubes");
    std::vector<LevelData> levels(2);
    LevelData* parents = nullptr;
    // Level L first, for watertightness; then 0 … L keeping only a level and its parents decoded.
    {
        LevelData finest = load_level(h_.max_level);
        report_.watertight = check_watertight(finest, false);
        report_ = VerifyReport{0, 0, 0, report_.watertight};
    }
    for (uint32_t l = 0; l <= h_.max_level; ++l) {
        progress_("verify", l, h_.max_level + 1, "level");
        LevelData& current = levels[l % 2];
        current = load_level(l);
        resolve_level(current, parents);
        if (l == 0) {
            if (current.nodes.size() != 1 || current.index.count(CubeKey{0, 0, 0}) == 0)
                fail("level 0 must be exactly the root cube");
        }
        parent_lookup_.assign(parents ? parents->cubes.size() : 0, {});
        for (size_t c = 0; c < current.cubes.size(); ++c) {
            check_cube_bounds(current, c);
            if (l == 0) check_root(current.cubes[c], *current.nodes[c]);
            else check_against_parent(current, c, *parents);
        }
        if (parents) check_parent_groups(current, *parents);
        if (report_.watertight) check_watertight(current, true);
        parents = &current;
    }
    progress_("verify", h_.max_level + 1, h_.max_level + 1, "level");
    return report_;
}

}  // namespace

VerifyReport verify_hlod(const HlodFile& file, const Progress& progress) {
    return Verifier(file, progress).run();
}

}  // namespace strata
