// What the builder's stages pass to each other (DESIGN.md §2): the octree's frame, cube and block
// keys, and the cube as it travels from one level to the next. A cube holds its own copy of every
// vertex it uses, so a block is simplified from its cubes alone, and the same cubes can come from
// memory or from disk.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "preprocess/hlod_format.h"
#include "preprocess/quadric.h"

namespace strata::build {

using CubeKey = uint64_t;  // k, j, i in 21 bits each: sorting keys orders cubes k-major
inline CubeKey make_key(uint64_t i, uint64_t j, uint64_t k) { return (k << 42) | (j << 21) | i; }
inline uint32_t key_i(CubeKey key) { return uint32_t(key & 0x1FFFFF); }
inline uint32_t key_j(CubeKey key) { return uint32_t((key >> 21) & 0x1FFFFF); }
inline uint32_t key_k(CubeKey key) { return uint32_t(key >> 42); }
inline CubeKey parent_key(CubeKey key) { return make_key(key_i(key) >> 1, key_j(key) >> 1, key_k(key) >> 1); }
inline uint32_t octant(CubeKey key) { return (key_i(key) & 1) | (key_j(key) & 1) << 1 | (key_k(key) & 1) << 2; }

struct Frame {
    double origin[3];
    double root_size;
    uint32_t max_level;
    uint32_t block;  // n
    float sigma0;

    double cube_size(uint32_t level) const { return root_size / double(uint64_t(1) << level); }
    // n×n×n cubes per block, the block grid offset so that the origin is a block centre (000 §3.2.4,
    // "second method"): block b spans cubes [b·n − n/2, b·n + n/2) on each axis. With n a multiple of 4,
    // each block splits into whole parent cubes, so a level-(l−1) cube comes from one level-l block.
    CubeKey block_of(CubeKey cube) const {
        return make_key((key_i(cube) + block / 2) / block, (key_j(cube) + block / 2) / block,
                        (key_k(cube) + block / 2) / block);
    }
    // Model coordinate of a block's lower corner on `axis` (its cube index b·n − n/2 times s_l).
    double block_low(CubeKey block_key, int axis, uint32_t level) const {
        const uint32_t b = axis == 0 ? key_i(block_key) : axis == 1 ? key_j(block_key) : key_k(block_key);
        return origin[axis] + (double(b) * block - double(block / 2)) * cube_size(level);
    }
};

// A coordinate on level `level`'s lattice, as stored relative to its cube's cell (FORMAT.md §6): q −
// 2^15·cell + 2^14 with q = round((x − O)/h_l), h_l a power of two over L_c. Every builder quantizes
// through it, so the copies of a vertex that cubes share agree bit for bit; the stored 16 bits hold it
// when it lies in [0, 0xFFFF], which callers check.
inline int64_t lattice_offset(const Frame& f, double x, int axis, uint32_t level, uint32_t cell) {
    const double inverse_step = double(uint64_t(1) << (level + kLatticeBits)) / f.root_size;
    return std::llround((x - f.origin[axis]) * inverse_step) - (int64_t(cell) << kLatticeBits) + kLatticeBias;
}

// A locked boundary's vertex (BuildSettings::lock_boundary) lies on level 0's lattice at every level:
// q0 = round((x − O)/h_0) once, and q = q0·2^l at level l, so that f32(q)·h_l is f32(q0)·h_0 scaled by
// 2^l and back, both exact, and every level decodes it to the same float (FORMAT.md §6). Its float x
// itself never changes: a boundary vertex is never collapsed, and its copies carry x from level to level.
inline int64_t boundary_q0(const Frame& f, double x, int axis) { return lattice_offset(f, x, axis, 0, 0) - kLatticeBias; }
inline int64_t boundary_lattice_offset(const Frame& f, double x, int axis, uint32_t level, uint32_t cell) {
    return boundary_q0(f, x, axis) * (int64_t(1) << level) - (int64_t(cell) << kLatticeBits) + kLatticeBias;
}
// Where a boundary vertex is drawn (up to the decode's float rounding): x snapped to level 0's lattice.
inline double snapped_to_root_lattice(const Frame& f, double x, int axis) {
    return f.origin[axis] + double(boundary_q0(f, x, axis)) * (f.root_size / double(1 << kLatticeBits));
}

// (a + b + c) / 3 in double: the point whose cell holds a triangle (000 §3.2.3; triangles are never cut).
inline std::array<double, 3> barycenter(const float* a, const float* b, const float* c) {
    return {(double(a[0]) + double(b[0]) + double(c[0])) / 3.0, (double(a[1]) + double(b[1]) + double(c[1])) / 3.0,
            (double(a[2]) + double(b[2]) + double(c[2])) / 3.0};
}

// The level-`level` cell holding a point, clamped to the grid.
inline CubeKey cell_of(const Frame& f, const std::array<double, 3>& point, uint32_t level) {
    const double scale = double(uint64_t(1) << level) / f.root_size;
    const int64_t last = (int64_t(1) << level) - 1;
    uint64_t cell[3];
    for (int x = 0; x < 3; ++x)
        cell[x] = uint64_t(std::clamp<int64_t>(int64_t(std::floor((point[size_t(x)] - f.origin[x]) * scale)), 0, last));
    return make_key(cell[0], cell[1], cell[2]);
}

// One cube of level l between two stages. Vertices [0, used_vertices) are those its triangles use,
// in the order the payload stores them; the rest are extras: parents its children need that none of
// its own triangles use (FORMAT.md "extra vertices").
struct CubeRecord {
    CubeKey key = 0;
    float error = 0;                         // against M_L, model units (0 at level L)
    std::vector<float> positions;            // 3 per vertex
    std::vector<uint8_t> colors;             // 4 per vertex, or empty
    std::vector<float> uvs;                  // 2 per vertex, or empty
    std::vector<float> normals;              // 3 per vertex: the scan's own, at level L only; or empty
    std::vector<uint8_t> boundary;           // 1 per vertex, 1 on the locked open boundary; empty: none is
    std::vector<uint32_t> triangles;         // 3 per triangle, into this cube's vertices, payload order
    std::array<uint32_t, 8> child_counts{};  // how the triangles split by the child they came from

    uint32_t vertex_count() const { return uint32_t(positions.size() / 3); }
    uint32_t triangle_count() const { return uint32_t(triangles.size() / 3); }
};

// Adds each of the cube's triangles' area-weighted normal (the cross product of two edges, whose length
// is twice the area) to the sums of its corners' points: point(v) is vertex v's row in `sums`.
template <class PointOf>
void add_area_normals(const CubeRecord& cube, PointOf&& point, std::vector<std::array<float, 3>>& sums) {
    for (size_t t = 0; t < cube.triangles.size(); t += 3) {
        const float* p[3];
        for (int c = 0; c < 3; ++c) p[c] = &cube.positions[3 * size_t(cube.triangles[t + c])];
        const Vec3 a{p[0][0], p[0][1], p[0][2]}, b{p[1][0], p[1][1], p[1][2]}, d{p[2][0], p[2][1], p[2][2]};
        const Vec3 n = cross(b - a, d - a);
        for (int c = 0; c < 3; ++c) {
            std::array<float, 3>& s = sums[point(cube.triangles[t + c])];
            s[0] += n.x, s[1] += n.y, s[2] += n.z;
        }
    }
}

// Puts a cube's triangles in the order its payload stores them: vertex-cache order within each child
// group (keeping the groups whole), then its vertices in first-use order. `indices` index `vertices`
// (ids of the caller's choosing), both rewritten in place.
void order_for_payload(std::vector<uint32_t>& indices, const std::array<uint32_t, 8>& child_counts,
                       std::vector<uint32_t>& vertices);

}  // namespace strata::build
