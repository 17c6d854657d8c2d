#include "preprocess/block_step.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "preprocess/error_bound.h"
#include "preprocess/index_map.h"
#include "preprocess/quadric.h"
#include "preprocess/simplify.h"

namespace strata::build {
namespace {

// Attribute weights in the collapse cost, against distances measured in cube sizes: a full-range
// colour change costs like moving a tenth of a cube; a UV change of 1 like moving half a cube.
constexpr float kColorWeight = 0.1f;
constexpr float kUvWeight = 0.5f;
// Scanned normals (level L only; coarser levels' normals come from their own triangles): a reversal
// costs like moving a fifth of a cube.
constexpr float kNormalWeight = 0.1f;

// The block's cubes as one mesh. A vertex is a *wedge* (position plus attributes): copies of one
// vertex in several cubes become one wedge. A *point* is a position, shared by the seam copies on it.
struct BlockWeld {
    std::vector<uint32_t> first;           // per cube: its first vertex in the block's numbering
    std::vector<uint32_t> vertex_cube;     // per block vertex: its cube
    std::vector<uint32_t> vertex_wedge;    // per block vertex (cube c's vertex v is first[c] + v)
    std::vector<uint32_t> wedge_vertex;    // per wedge: the block vertex it was first seen as
    std::vector<uint32_t> wedge_point;
    std::vector<uint32_t> point_wedge;     // per point: its first wedge
    std::vector<std::array<int16_t, 2>> wedge_normal;  // octahedral, final for this level
    std::vector<uint8_t> point_locked;

    uint32_t wedge_count() const { return uint32_t(wedge_vertex.size()); }
    uint32_t point_count() const { return uint32_t(point_wedge.size()); }
};

// Where block vertex g lives.
struct VertexRef {
    const CubeRecord* cube;
    uint32_t v;
};

class BlockVertices {
public:
    BlockVertices(std::span<const CubeRecord* const> cubes, const BlockWeld& w) : cubes_(cubes), w_(w) {}
    VertexRef operator[](uint32_t g) const {
        const uint32_t c = w_.vertex_cube[g];
        return {cubes_[c], g - w_.first[c]};
    }

private:
    std::span<const CubeRecord* const> cubes_;
    const BlockWeld& w_;
};

const float* position_of(VertexRef r) { return &r.cube->positions[3 * size_t(r.v)]; }

bool on_boundary(VertexRef r) { return !r.cube->boundary.empty() && r.cube->boundary[r.v]; }

// Where a vertex is drawn, up to its lattice's rounding: a locked boundary's vertex snapped to level 0's
// lattice. Collapse targets and parents are held to the travel bound there, so that it holds as decoded.
std::array<double, 3> drawn_position(VertexRef r, const Frame& f) {
    const float* x = position_of(r);
    if (!on_boundary(r)) return {x[0], x[1], x[2]};
    return {snapped_to_root_lattice(f, x[0], 0), snapped_to_root_lattice(f, x[1], 1), snapped_to_root_lattice(f, x[2], 2)};
}

bool same_wedge(VertexRef a, VertexRef b) {
    auto same = [](const auto& x, const auto& y, size_t i, size_t j, size_t n) {
        return x.empty() || std::memcmp(&x[n * i], &y[n * j], n * sizeof(x[0])) == 0;
    };
    return position_bits(position_of(a)) == position_bits(position_of(b)) &&
           same(a.cube->colors, b.cube->colors, a.v, b.v, 4) && same(a.cube->uvs, b.cube->uvs, a.v, b.v, 2) &&
           same(a.cube->normals, b.cube->normals, a.v, b.v, 3);
}

uint64_t hash_wedge(VertexRef r) {
    uint64_t h = hash_position(position_bits(position_of(r)));
    if (!r.cube->colors.empty()) {
        uint32_t rgba;
        std::memcpy(&rgba, &r.cube->colors[4 * size_t(r.v)], 4);
        h ^= uint64_t(rgba) * 0x9E3779B97F4A7C15ull;
    }
    return h;
}

// Welds the cubes, decides which points are locked (another block lists them, or they lie on the locked
// boundary) and every wedge's normal: the scan's own at level L when it has them, else the area-weighted
// sum over the level's triangles at the point (DESIGN.md §2: across cube and block borders).
BlockWeld weld_block(std::span<const CubeRecord* const> cubes, const BorderTable& border, CubeKey block) {
    BlockWeld w;
    uint32_t total = 0;
    for (const CubeRecord* c : cubes) w.first.push_back(total), total += c->vertex_count();
    w.vertex_cube.resize(total);
    for (uint32_t c = 0; c < cubes.size(); ++c)
        std::fill_n(w.vertex_cube.begin() + w.first[c], cubes[c]->vertex_count(), c);
    const BlockVertices vertex(cubes, w);

    w.wedge_vertex = number_distinct(
        total, [&](uint32_t g) { return hash_wedge(vertex[g]); },
        [&](uint32_t a, uint32_t b) { return same_wedge(vertex[a], vertex[b]); }, w.vertex_wedge);
    auto wedge_bits = [&](uint32_t e) { return position_bits(position_of(vertex[w.wedge_vertex[e]])); };
    w.point_wedge = number_distinct(
        w.wedge_count(), [&](uint32_t e) { return hash_position(wedge_bits(e)); },
        [&](uint32_t a, uint32_t b) { return wedge_bits(a) == wedge_bits(b); }, w.wedge_point);

    std::vector<std::array<float, 3>> sums(w.point_count(), {0, 0, 0});
    for (size_t c = 0; c < cubes.size(); ++c)
        add_area_normals(*cubes[c], [&](uint32_t v) { return w.wedge_point[w.vertex_wedge[w.first[c] + v]]; }, sums);
    w.point_locked.assign(w.point_count(), 0);
    for (uint32_t p = 0; p < w.point_count(); ++p) {
        const VertexRef r = vertex[w.wedge_vertex[w.point_wedge[p]]];
        w.point_locked[p] = on_boundary(r);  // every copy at the point carries the flag
        const BorderTable::Point* shared = border.find(position_bits(position_of(r)));
        if (!shared) continue;
        w.point_locked[p] |= shared->locked_for(block);
        sums[p] = shared->normal_sum;
    }
    w.wedge_normal.resize(w.wedge_count());
    for (uint32_t e = 0; e < w.wedge_count(); ++e) {
        const VertexRef r = vertex[w.wedge_vertex[e]];
        const float* n = r.cube->normals.empty() ? sums[w.wedge_point[e]].data() : &r.cube->normals[3 * size_t(r.v)];
        w.wedge_normal[e] = encode_normal(n[0], n[1], n[2]);
    }
    return w;
}

// A vertex's stored lattice coordinate (lattice_offset; boundary_lattice_offset on a locked boundary),
// which its cell's σ0 overhang keeps in range.
uint16_t lattice(const Frame& f, float x, int axis, uint32_t level, uint32_t cell, bool boundary) {
    const int64_t stored = boundary ? boundary_lattice_offset(f, x, axis, level, cell) : lattice_offset(f, x, axis, level, cell);
    if (stored < 0 || stored > 0xFFFF)
        throw std::runtime_error("internal error: a level-" + std::to_string(level) +
                                 " vertex lies outside its cell's σ0 overhang");
    return uint16_t(stored);
}

// A level-l cube's payload: its vertices on the level's lattice with their final normals, and per
// vertex its parent's index in the parent cube.
EncodedCube encode(const CubeRecord& cube, uint32_t level, const BlockWeld& w, uint32_t first,
                   std::span<const uint32_t> parent_vertex, const Frame& f, uint32_t flags) {
    CubeData data;
    const uint32_t cell[3] = {key_i(cube.key), key_j(cube.key), key_k(cube.key)};
    const uint32_t n = cube.vertex_count();
    data.vertices.positions.resize(3 * size_t(n));
    data.vertices.normals.resize(2 * size_t(n));
    for (uint32_t v = 0; v < n; ++v) {
        const bool boundary = !cube.boundary.empty() && cube.boundary[v];
        for (int a = 0; a < 3; ++a)
            data.vertices.positions[3 * size_t(v) + a] = lattice(f, cube.positions[3 * size_t(v) + a], a, level, cell[a], boundary);
        const std::array<int16_t, 2>& normal = w.wedge_normal[w.vertex_wedge[first + v]];
        data.vertices.normals[2 * size_t(v)] = normal[0], data.vertices.normals[2 * size_t(v) + 1] = normal[1];
    }
    if (flags & kHasColors) data.vertices.colors = cube.colors;
    if (flags & kHasUvs) data.vertices.uvs = cube.uvs;
    data.parent_vertex.assign(parent_vertex.begin(), parent_vertex.end());
    data.indices = cube.triangles;
    data.child_triangle_counts = cube.child_counts;

    EncodedCube out;
    out.node.level = level;
    out.node.i = cell[0], out.node.j = cell[1], out.node.k = cell[2];
    out.node.error = cube.error;
    out.node.vertex_count = data.vertex_count();
    out.node.triangle_count = data.triangle_count();
    out.payload = encode_cube(data, flags);
    return out;
}

BlockMesh block_mesh(std::span<const CubeRecord* const> cubes, const BlockWeld& w, const Frame& f, uint32_t level) {
    const CubeKey block = f.block_of(cubes[0]->key);
    const double size = f.cube_size(level);
    double center[3];
    for (int a = 0; a < 3; ++a) center[a] = f.block_low(block, a, level) + f.block / 2 * size;
    const BlockVertices vertex(cubes, w);
    const CubeRecord& any = *cubes[0];

    BlockMesh m;
    m.attribute_count = (any.colors.empty() ? 0 : 4) + (any.uvs.empty() ? 0 : 2) + (any.normals.empty() ? 0 : 3);
    m.point_positions.reserve(3 * size_t(w.point_count()));
    for (uint32_t p = 0; p < w.point_count(); ++p) {
        const std::array<double, 3> x = drawn_position(vertex[w.wedge_vertex[w.point_wedge[p]]], f);
        for (int a = 0; a < 3; ++a) m.point_positions.push_back(float((x[size_t(a)] - center[a]) / size));
    }
    m.point_locked = w.point_locked;
    m.wedge_point = w.wedge_point;
    m.wedge_attributes.reserve(size_t(m.attribute_count) * w.wedge_count());
    for (uint32_t e = 0; e < w.wedge_count(); ++e) {
        const VertexRef r = vertex[w.wedge_vertex[e]];
        for (int k = 0; k < 4 && !r.cube->colors.empty(); ++k)
            m.wedge_attributes.push_back(r.cube->colors[4 * size_t(r.v) + k] * (kColorWeight / 255.0f));
        for (int k = 0; k < 2 && !r.cube->uvs.empty(); ++k) m.wedge_attributes.push_back(r.cube->uvs[2 * size_t(r.v) + k] * kUvWeight);
        if (!r.cube->normals.empty())
            for (float x : decode_normal(w.wedge_normal[e][0], w.wedge_normal[e][1])) m.wedge_attributes.push_back(x * kNormalWeight);
    }
    for (size_t c = 0; c < cubes.size(); ++c)
        for (uint32_t i : cubes[c]->triangles) m.triangles.push_back(w.vertex_wedge[w.first[c] + i]);
    return m;
}

// The parent for a child's own extra vertex (one no triangle of its cube uses, so nothing draws it and
// no triangle degenerates onto its parent): the parent's nearest used vertex within `reach` (d∞), the
// travel bound verify holds parents to; IndexMap::kMissing when none is that near. Without it an
// extra would be its own parent, an extra again, level after level: the root of a billion-triangle
// model held 207 840 vertices for 3 898 triangles.
uint32_t nearest_used(const std::array<double, 3>& p, const std::vector<std::array<double, 3>>& used_positions, double reach) {
    uint32_t best = IndexMap::kMissing;
    double best_squared = 0;
    for (uint32_t i = 0; i < used_positions.size(); ++i) {
        const std::array<double, 3>& q = used_positions[i];
        const double d[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
        if (std::fabs(d[0]) > reach || std::fabs(d[1]) > reach || std::fabs(d[2]) > reach) continue;
        const double squared = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if (best == IndexMap::kMissing || squared < best_squared) best = i, best_squared = squared;
    }
    return best;
}

// The level-(l−1) cube made of children [begin, end) (one parent, in octant order): their surviving
// triangles, its vertices in payload order then the extras, and each child vertex's parent index.
// `reach`: how far (d∞, frame units) a child's extra vertex may be from its parent.
CubeRecord make_parent(std::span<const CubeRecord* const> cubes, std::span<const uint32_t> children, const BlockWeld& w,
                       const SimplifyResult& result, const Frame& f, double reach, std::vector<uint32_t>& parent_vertex) {
    const BlockVertices vertex(cubes, w);
    CubeRecord parent;
    parent.key = parent_key(cubes[children[0]]->key);
    std::vector<uint32_t> wedges;  // the parent's vertices, as block wedges
    IndexMap local_of(1024);
    for (uint32_t c : children) {
        const CubeRecord& child = *cubes[c];
        uint32_t kept = 0;
        for (size_t t = 0; t < child.triangles.size(); t += 3) {
            uint32_t corner[3], point[3];
            for (int k = 0; k < 3; ++k) {
                corner[k] = result.wedge_remap[w.vertex_wedge[w.first[c] + child.triangles[t + k]]];
                point[k] = w.wedge_point[corner[k]];
            }
            if (point[0] == point[1] || point[1] == point[2] || point[0] == point[2]) continue;
            for (int k = 0; k < 3; ++k) {
                const uint32_t local = local_of.find_or_insert(corner[k], uint32_t(wedges.size()));
                if (local == wedges.size()) wedges.push_back(corner[k]);
                parent.triangles.push_back(local);
            }
            ++kept;
        }
        parent.child_counts[octant(child.key)] += kept;
    }
    order_for_payload(parent.triangles, parent.child_counts, wedges);

    const uint32_t used = uint32_t(wedges.size());
    IndexMap index_of(wedges.size() + 64);
    for (uint32_t i = 0; i < used; ++i) index_of.find_or_insert(wedges[i], i);
    std::vector<std::array<double, 3>> used_positions;  // filled when a child's extra first needs a parent
    std::vector<uint8_t> drawn;
    for (uint32_t c : children) {
        const CubeRecord& child = *cubes[c];
        drawn.assign(child.vertex_count(), 0);
        for (uint32_t i : child.triangles) drawn[i] = 1;
        for (uint32_t v = 0; v < child.vertex_count(); ++v) {
            const uint32_t target = result.wedge_remap[w.vertex_wedge[w.first[c] + v]];
            uint32_t index = index_of.find(target);
            if (index == IndexMap::kMissing && !drawn[v]) {
                if (used_positions.empty())
                    for (uint32_t i = 0; i < used; ++i) used_positions.push_back(drawn_position(vertex[w.wedge_vertex[wedges[i]]], f));
                index = nearest_used(drawn_position(vertex[w.first[c] + v], f), used_positions, reach);
            }
            if (index == IndexMap::kMissing) {  // an extra vertex
                index = index_of.find_or_insert(target, uint32_t(wedges.size()));
                if (index == wedges.size()) wedges.push_back(target);
            }
            parent_vertex[w.first[c] + v] = index;
        }
    }

    const CubeRecord& any = *cubes[0];
    for (uint32_t e : wedges) {
        const VertexRef r = vertex[w.wedge_vertex[e]];
        parent.positions.insert(parent.positions.end(), position_of(r), position_of(r) + 3);
        if (!any.colors.empty()) parent.colors.insert(parent.colors.end(), &r.cube->colors[4 * size_t(r.v)], &r.cube->colors[4 * size_t(r.v) + 4]);
        if (!any.uvs.empty()) parent.uvs.insert(parent.uvs.end(), &r.cube->uvs[2 * size_t(r.v)], &r.cube->uvs[2 * size_t(r.v) + 2]);
        parent.boundary.push_back(on_boundary(r));
    }
    if (std::find(parent.boundary.begin(), parent.boundary.end(), 1) == parent.boundary.end()) parent.boundary.clear();
    return parent;
}

}  // namespace

BlockOutput simplify_block_cubes(std::span<const CubeRecord* const> cubes, uint32_t level, const BorderTable& border,
                                 const Frame& f, const BuildSettings& s, uint32_t flags) {
    const BlockWeld w = weld_block(cubes, border, f.block_of(cubes[0]->key));
    uint32_t block_triangles = 0;
    for (const CubeRecord* c : cubes) block_triangles += c->triangle_count();

    SimplifyLimits limits;
    limits.target_triangles = uint32_t(std::ceil(double(block_triangles) * s.ratio));
    limits.max_travel = f.sigma0 * 0.5f;                 // σ0·s_{l+1}, in cube sizes
    limits.min_fold = 2.0f / float(1 << kLatticeBits);  // h_{l−1}, in cube sizes
    if (s.error > 0) limits.max_error = s.error * 2.0f;  // ε_q·s_{l−1}, in cube sizes
    const SimplifyResult result = simplify_block(block_mesh(cubes, w, f, level), limits);

    // Children grouped by parent, in octant order; parents then come out in key order.
    std::vector<uint32_t> children(cubes.size());
    for (uint32_t c = 0; c < cubes.size(); ++c) children[c] = c;
    std::sort(children.begin(), children.end(), [&](uint32_t a, uint32_t b) {
        const CubeKey pa = parent_key(cubes[a]->key), pb = parent_key(cubes[b]->key);
        return pa < pb || (pa == pb && octant(cubes[a]->key) < octant(cubes[b]->key));
    });
    BlockOutput out;
    std::vector<uint32_t> parent_vertex(w.vertex_wedge.size());
    const double size = f.cube_size(level);
    for (size_t i = 0, j; i < children.size(); i = j) {
        const CubeKey key = parent_key(cubes[children[i]]->key);
        for (j = i; j < children.size() && parent_key(cubes[children[j]]->key) == key; ++j) {
        }
        out.parents.push_back(
            make_parent(cubes, std::span(children).subspan(i, j - i), w, result, f, f.sigma0 * 0.5 * size, parent_vertex));
        list_border_points(out.parents.back(), f, level - 1, out.border);
    }
    const StepBounds bounds = bound_step(cubes, out.parents, f.cube_size(level - 1));
    for (size_t p = 0; p < out.parents.size(); ++p) out.parents[p].error = bounds.parent_forward[p];
    for (size_t c = 0; c < cubes.size(); ++c) {
        out.encoded.push_back(encode(*cubes[c], level, w, w.first[c],
                                     std::span(parent_vertex).subspan(w.first[c], cubes[c]->vertex_count()), f, flags));
        out.encoded.back().coverage = bounds.cube_coverage[c];
    }
    return out;
}

EncodedCube encode_root(const CubeRecord& root, const BorderTable& border, const Frame& f, uint32_t flags) {
    const CubeRecord* cubes[1] = {&root};
    const BlockWeld w = weld_block(cubes, border, f.block_of(root.key));
    std::vector<uint32_t> itself(root.vertex_count());
    for (uint32_t v = 0; v < root.vertex_count(); ++v) itself[v] = v;
    return encode(root, 0, w, 0, itself, f, flags);
}

}  // namespace strata::build
