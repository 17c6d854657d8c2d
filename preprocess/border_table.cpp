#include "preprocess/border_table.h"

#include <algorithm>
#include <cstring>

#include "preprocess/index_map.h"
#include "preprocess/quadric.h"

namespace strata::build {

PositionBits position_bits(const float* position) {
    PositionBits bits;
    for (int a = 0; a < 3; ++a) {
        const float x = position[a] + 0.0f;  // −0 → +0
        std::memcpy(&bits[a], &x, 4);
    }
    return bits;
}

uint64_t hash_position(const PositionBits& bits) {
    return (uint64_t(bits[0]) * 73856093u) ^ (uint64_t(bits[1]) * 19349663u) ^ (uint64_t(bits[2]) * 83492791u);
}

uint32_t weld_positions(const float* positions, uint32_t count, std::vector<uint32_t>& point_of) {
    point_of.resize(count);
    IndexMap first(count);
    std::vector<uint32_t> point_of_first(count);
    uint32_t points = 0;
    for (uint32_t v = 0; v < count; ++v) {
        const PositionBits bits = position_bits(&positions[3 * size_t(v)]);
        const uint32_t found = first.find_or_insert(hash_position(bits), v, [&](uint32_t other) {
            return position_bits(&positions[3 * size_t(other)]) == bits;
        });
        if (found == v) point_of_first[v] = points++;
        point_of[v] = point_of_first[found];
    }
    return points;
}

namespace {

// Points on an edge whose two directions are not used equally often: where the cube's surface stops
// (it continues in a neighbour, or the model ends there).
std::vector<uint8_t> open_points(const std::vector<uint32_t>& triangles, const std::vector<uint32_t>& point_of,
                                 uint32_t points) {
    // (min, max) with +1 for a → b where a < b and −1 for the reverse: a closed edge sums to zero.
    std::vector<std::pair<uint64_t, int>> edges;
    edges.reserve(triangles.size());
    for (size_t t = 0; t < triangles.size(); t += 3)
        for (int c = 0; c < 3; ++c) {
            const uint32_t a = point_of[triangles[t + c]], b = point_of[triangles[t + (c + 1) % 3]];
            if (a == b) continue;
            edges.emplace_back(uint64_t(std::min(a, b)) << 32 | std::max(a, b), a < b ? 1 : -1);
        }
    std::sort(edges.begin(), edges.end());
    std::vector<uint8_t> open(points, 0);
    for (size_t i = 0, j; i < edges.size(); i = j) {
        int balance = 0;
        for (j = i; j < edges.size() && edges[j].first == edges[i].first; ++j) balance += edges[j].second;
        if (balance != 0) open[edges[i].first >> 32] = open[uint32_t(edges[i].first)] = 1;
    }
    return open;
}

}  // namespace

void list_border_points(const CubeRecord& cube, const Frame& frame, uint32_t level, std::vector<BorderEntry>& out) {
    std::vector<uint32_t> point_of;
    const uint32_t points = weld_positions(cube.positions.data(), cube.vertex_count(), point_of);
    const std::vector<uint8_t> open = open_points(cube.triangles, point_of, points);

    std::vector<std::array<float, 3>> sums(points, {0, 0, 0});
    for (size_t t = 0; t < cube.triangles.size(); t += 3) {
        const float* p[3];
        for (int c = 0; c < 3; ++c) p[c] = &cube.positions[3 * size_t(cube.triangles[t + c])];
        const Vec3 a{p[0][0], p[0][1], p[0][2]}, b{p[1][0], p[1][1], p[1][2]}, d{p[2][0], p[2][1], p[2][2]};
        const Vec3 n = cross(b - a, d - a);  // length = twice the area: the area weighting
        for (int c = 0; c < 3; ++c) {
            std::array<float, 3>& s = sums[point_of[cube.triangles[t + c]]];
            s[0] += n.x, s[1] += n.y, s[2] += n.z;
        }
    }

    const CubeKey block = frame.block_of(cube.key);
    const double size = frame.cube_size(level);
    // σ0·s_l, plus rounding slack: the lattice step and float positions far from the origin.
    const double reach = frame.sigma0 * size * 1.001 + size * 1e-4;
    double low[3], high[3];
    for (int a = 0; a < 3; ++a) {
        low[a] = frame.block_low(block, a, level) + reach;
        high[a] = low[a] - 2 * reach + frame.block * size;
    }
    std::vector<uint8_t> listed(points, 0);
    for (uint32_t v = 0; v < cube.vertex_count(); ++v) {
        const uint32_t p = point_of[v];
        if (!open[p] || listed[p]) continue;
        const float* x = &cube.positions[3 * size_t(v)];
        bool near = false;
        for (int a = 0; a < 3; ++a) near |= !(x[a] > low[a] && x[a] < high[a]);
        if (!near) continue;
        listed[p] = 1;
        out.push_back(BorderEntry{position_bits(x), block, cube.key, sums[p]});
    }
}

BorderTable::BorderTable(std::vector<BorderEntry> entries) {
    std::sort(entries.begin(), entries.end(), [](const BorderEntry& a, const BorderEntry& b) {
        return a.position < b.position || (a.position == b.position && a.cube < b.cube);
    });
    for (size_t i = 0; i < entries.size(); ++i) {
        const BorderEntry& e = entries[i];
        if (i == 0 || e.position != entries[i - 1].position) {
            positions_.push_back(e.position);
            points_.push_back(Point{e.block, false, {0, 0, 0}});
        }
        Point& point = points_.back();
        point.several_blocks |= e.block != point.first_block;
        for (int a = 0; a < 3; ++a) point.normal_sum[a] += e.normal_sum[a];
    }
}

const BorderTable::Point* BorderTable::find(const PositionBits& position) const {
    const auto it = std::lower_bound(positions_.begin(), positions_.end(), position);
    if (it == positions_.end() || *it != position) return nullptr;
    return &points_[size_t(it - positions_.begin())];
}

}  // namespace strata::build
