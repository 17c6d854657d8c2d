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
    auto bits = [&](uint32_t v) { return position_bits(&positions[3 * size_t(v)]); };
    return uint32_t(number_distinct(
                        count, [&](uint32_t v) { return hash_position(bits(v)); },
                        [&](uint32_t a, uint32_t b) { return bits(a) == bits(b); }, point_of)
                        .size());
}

namespace {

// Marks the points on an edge whose two directions are not used equally often: where the cube's
// surface stops (it continues in a neighbour, or the model ends there). Only edges with an end in
// `wanted` are looked at. Each point's outgoing edges are counted against the reverse direction in
// the far end's (sorted) list: linear in the edges, even around a high-valence point.
void mark_open_points(const std::vector<uint32_t>& triangles, const std::vector<uint32_t>& point_of,
                      const std::vector<uint8_t>& wanted, std::vector<uint8_t>& open) {
    const uint32_t points = uint32_t(wanted.size());
    std::vector<uint32_t> offsets(size_t(points) + 1, 0);
    auto for_each_edge = [&](auto&& fn) {
        for (size_t t = 0; t < triangles.size(); t += 3)
            for (int c = 0; c < 3; ++c) {
                const uint32_t a = point_of[triangles[t + c]], b = point_of[triangles[t + (c + 1) % 3]];
                if (a != b && (wanted[a] || wanted[b])) fn(a, b);
            }
    };
    for_each_edge([&](uint32_t a, uint32_t) { ++offsets[a + 1]; });
    for (uint32_t p = 0; p < points; ++p) offsets[p + 1] += offsets[p];
    std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1), targets(offsets.back());
    for_each_edge([&](uint32_t a, uint32_t b) { targets[fill[a]++] = b; });
    for (uint32_t p = 0; p < points; ++p) std::sort(&targets[offsets[p]], &targets[offsets[p + 1]]);

    open.assign(points, 0);
    for (uint32_t a = 0; a < points; ++a)
        for (uint32_t i = offsets[a], j; i < offsets[a + 1]; i = j) {
            const uint32_t b = targets[i];
            for (j = i; j < offsets[a + 1] && targets[j] == b; ++j) {
            }
            const auto back = std::equal_range(&targets[offsets[b]], &targets[offsets[b + 1]], a);
            if (back.second - back.first != std::ptrdiff_t(j - i)) open[a] = open[b] = 1;
        }
}

}  // namespace

void list_border_points(const CubeRecord& cube, const Frame& frame, uint32_t level, std::vector<BorderEntry>& out) {
    const CubeKey block = frame.block_of(cube.key);
    const double size = frame.cube_size(level);
    // σ0·s_l, plus rounding slack: the lattice step and float positions far from the origin.
    const double reach = frame.sigma0 * size * 1.001 + size * 1e-4;
    double low[3], high[3];
    for (int a = 0; a < 3; ++a) {
        low[a] = frame.block_low(block, a, level) + reach;
        high[a] = low[a] - 2 * reach + frame.block * size;
    }
    auto near_border = [&](const float* x) {
        bool near = false;
        for (int a = 0; a < 3; ++a) near |= !(x[a] > low[a] && x[a] < high[a]);
        return near;
    };
    uint32_t first_near = 0;
    while (first_near < cube.vertex_count() && !near_border(&cube.positions[3 * size_t(first_near)])) ++first_near;
    if (first_near == cube.vertex_count()) return;  // deep inside its block: no other block can use its points

    std::vector<uint32_t> point_of;
    const uint32_t points = weld_positions(cube.positions.data(), cube.vertex_count(), point_of);
    std::vector<uint8_t> near(points, 0);
    for (uint32_t v = first_near; v < cube.vertex_count(); ++v)
        if (!near[point_of[v]]) near[point_of[v]] = near_border(&cube.positions[3 * size_t(v)]);
    std::vector<uint8_t> open;
    mark_open_points(cube.triangles, point_of, near, open);

    std::vector<std::array<float, 3>> sums(points, {0, 0, 0});
    add_area_normals(cube, [&](uint32_t v) { return point_of[v]; }, sums);

    std::vector<uint8_t> listed(points, 0);
    for (uint32_t v = first_near; v < cube.vertex_count(); ++v) {
        const uint32_t p = point_of[v];
        if (!open[p] || !near[p] || listed[p]) continue;
        listed[p] = 1;
        out.push_back(BorderEntry{position_bits(&cube.positions[3 * size_t(v)]), block, cube.key, sums[p]});
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
    index_.reset(positions_.size());
    for (uint32_t i = 0; i < positions_.size(); ++i)
        index_.find_or_insert(hash_position(positions_[i]), i, [](uint32_t) { return false; });  // all distinct
}

const BorderTable::Point* BorderTable::find(const PositionBits& position) const {
    const uint32_t i = index_.find(hash_position(position), [&](uint32_t stored) { return positions_[stored] == position; });
    return i == IndexMap::kMissing ? nullptr : &points_[i];
}

BorderTable block_border_table(const std::vector<BorderEntry>& candidates, CubeKey block, const Frame& f, uint32_t level) {
    const double size = f.cube_size(level);
    const double reach = f.sigma0 * size * 1.001 + size * 1e-4;  // as list_border_points() reaches
    double low[3], high[3];
    for (int a = 0; a < 3; ++a) {
        low[a] = f.block_low(block, a, level) - reach;
        high[a] = low[a] + 2 * reach + f.block * size;
    }
    std::vector<BorderEntry> near;
    for (const BorderEntry& e : candidates) {
        float x[3];
        std::memcpy(x, e.position.data(), 12);
        bool inside = true;
        for (int a = 0; a < 3; ++a) inside &= x[a] >= low[a] && x[a] <= high[a];
        if (inside) near.push_back(e);
    }
    return BorderTable(std::move(near));
}

}  // namespace strata::build
