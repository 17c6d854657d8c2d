#include "preprocess/leaf_cubes.h"

#include <numeric>
#include <span>

#include "preprocess/index_map.h"
#include "preprocess/parallel.h"
#include "preprocess/radix_sort.h"

namespace strata::build {
namespace {

// One cube's record from its triangles (ids into the mesh's triangles).
CubeRecord make_leaf(const Mesh& mesh, CubeKey key, std::span<const uint32_t> triangles) {
    CubeRecord cube;
    cube.key = key;
    cube.child_counts[0] = uint32_t(triangles.size());
    std::vector<uint32_t> vertices;
    cube.triangles.resize(3 * triangles.size());
    IndexMap local_of(triangles.size() / 2 + 16);  // about half as many vertices as triangles
    for (size_t i = 0; i < 3 * triangles.size(); ++i) {
        const uint32_t v = mesh.indices[3 * size_t(triangles[i / 3]) + i % 3];
        const uint32_t local = local_of.find_or_insert(v, uint32_t(vertices.size()));
        if (local == vertices.size()) vertices.push_back(v);
        cube.triangles[i] = local;
    }
    order_for_payload(cube.triangles, cube.child_counts, vertices);
    auto copy = [&](const auto& from, auto& to, size_t per_vertex) {
        if (from.empty()) return;
        to.reserve(per_vertex * vertices.size());
        for (uint32_t v : vertices) to.insert(to.end(), &from[per_vertex * v], &from[per_vertex * v] + per_vertex);
    };
    copy(mesh.positions, cube.positions, 3);
    copy(mesh.colors, cube.colors, 4);
    copy(mesh.uvs, cube.uvs, 2);
    copy(mesh.normals, cube.normals, 3);
    return cube;
}

}  // namespace

std::vector<BorderEntry> leaf_cubes(Mesh& mesh, const Frame& f, unsigned threads, CubeStore& store) {
    const uint32_t L = f.max_level;
    const size_t triangles = mesh.triangle_count();
    // Sort by the dense linear index k·4^L + j·2^L + i (same order as CubeKey, fewer bits to sort).
    std::vector<uint64_t> linear(triangles);
    constexpr size_t kChunk = 1 << 16;
    parallel_for((triangles + kChunk - 1) / kChunk, threads, [&](size_t chunk, unsigned) {
        for (size_t t = chunk * kChunk; t < std::min(triangles, (chunk + 1) * kChunk); ++t) {
            const uint32_t* tri = &mesh.indices[3 * t];
            auto c = cell_of(f, &mesh.positions[3 * tri[0]], &mesh.positions[3 * tri[1]], &mesh.positions[3 * tri[2]], L);
            linear[t] = uint64_t(c[2]) << (2 * L) | uint64_t(c[1]) << L | uint64_t(c[0]);
        }
    });
    std::vector<uint32_t> order(triangles);
    std::iota(order.begin(), order.end(), 0u);
    radix_sort_ids(linear, order, int(3 * L));

    struct Range {
        CubeKey key;
        size_t first, count;
    };
    const uint64_t mask = (uint64_t(1) << L) - 1;
    std::vector<Range> ranges;
    for (size_t t = 0; t < triangles; ++t) {
        const uint64_t cell = linear[order[t]];
        if (t == 0 || cell != linear[order[t - 1]])
            ranges.push_back(Range{make_key(cell & mask, (cell >> L) & mask, cell >> (2 * L)), t, 0});
        ++ranges.back().count;
    }
    std::vector<uint64_t>().swap(linear);

    std::vector<std::vector<BorderEntry>> border(ranges.size());
    parallel_for(ranges.size(), threads, [&](size_t c, unsigned) {
        const CubeRecord cube = make_leaf(mesh, ranges[c].key, std::span(order).subspan(ranges[c].first, ranges[c].count));
        list_border_points(cube, f, L, border[c]);
        store.put(cube);
    });
    mesh = Mesh{};
    std::vector<BorderEntry> all;
    for (auto& entries : border) all.insert(all.end(), entries.begin(), entries.end());
    return all;
}

}  // namespace strata::build
