#include "preprocess/leaf_cubes.h"

#include <algorithm>
#include <cstring>
#include <span>

#include "preprocess/index_map.h"

namespace strata::build {
namespace {

uint64_t hash_bytes(const uint8_t* p, size_t size) {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (size_t i = 0; i + 4 <= size; i += 4) {
        uint32_t word;
        std::memcpy(&word, p + i, 4);
        h = (h ^ word) * 0xff51afd7ed558ccdull;
        h ^= h >> 32;
    }
    return h;
}

// One cube's record from its triangles (ids into the block's spilled triangles, in input order).
CubeRecord make_leaf(const uint8_t* records, const CornerLayout& layout, CubeKey key, std::span<const uint32_t> triangles) {
    const size_t corner_bytes = layout.bytes();
    auto corner = [&](uint32_t i) { return records + (3 * size_t(triangles[i / 3]) + i % 3) * corner_bytes; };
    CubeRecord cube;
    cube.key = key;
    cube.child_counts[0] = uint32_t(triangles.size());
    std::vector<uint32_t> vertices = number_distinct(
        uint32_t(3 * triangles.size()), [&](uint32_t i) { return hash_bytes(corner(i), corner_bytes); },
        [&](uint32_t a, uint32_t b) { return std::memcmp(corner(a), corner(b), corner_bytes) == 0; }, cube.triangles);
    order_for_payload(cube.triangles, cube.child_counts, vertices);
    const size_t n = vertices.size();
    cube.positions.resize(3 * n);
    if (layout.kept.normals) cube.normals.resize(3 * n);
    if (layout.kept.colors) cube.colors.resize(4 * n);
    if (layout.kept.uvs) cube.uvs.resize(2 * n);
    for (size_t v = 0; v < n; ++v) {
        const uint8_t* c = corner(vertices[v]);
        std::memcpy(&cube.positions[3 * v], c, 12);
        if (layout.kept.normals) std::memcpy(&cube.normals[3 * v], c + layout.normal_offset(), 12);
        if (layout.kept.colors) std::memcpy(&cube.colors[4 * v], c + layout.color_offset(), 4);
        if (layout.kept.uvs) std::memcpy(&cube.uvs[2 * v], c + layout.uv_offset(), 8);
    }
    return cube;
}

}  // namespace

LeafBlock leaf_block(const std::vector<uint8_t>& records, const CornerLayout& layout, const Frame& f) {
    const size_t triangle_bytes = 3 * layout.bytes(), step = layout.bytes() / 4;  // a corner in floats
    const size_t triangles = records.size() / triangle_bytes;
    std::vector<std::pair<CubeKey, uint32_t>> order(triangles);
    for (size_t t = 0; t < triangles; ++t) {
        const float* p = reinterpret_cast<const float*>(&records[t * triangle_bytes]);
        order[t] = {cell_of(f, barycenter(p, p + step, p + 2 * step), f.max_level), uint32_t(t)};
    }
    std::sort(order.begin(), order.end());  // by cube, then input order
    std::vector<uint32_t> ids(triangles);
    for (size_t t = 0; t < triangles; ++t) ids[t] = order[t].second;
    LeafBlock block;
    for (size_t first = 0, last; first < triangles; first = last) {
        for (last = first; last < triangles && order[last].first == order[first].first; ++last) {
        }
        block.cubes.push_back(make_leaf(records.data(), layout, order[first].first, std::span(ids).subspan(first, last - first)));
        list_border_points(block.cubes.back(), f, f.max_level, block.border);
    }
    return block;
}

}  // namespace strata::build
