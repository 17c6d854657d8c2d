#include "preprocess/open_boundary.h"

#include <algorithm>

namespace strata::build {
namespace {

// One of each run of equal edges whose length is odd (`edges` sorted).
std::vector<OpenEdge> keep_odd(const std::vector<OpenEdge>& edges) {
    std::vector<OpenEdge> odd;
    for (size_t first = 0, last; first < edges.size(); first = last) {
        for (last = first; last < edges.size() && edges[last] == edges[first]; ++last) {
        }
        if ((last - first) % 2) odd.push_back(edges[first]);
    }
    return odd;
}

}  // namespace

std::vector<OpenEdge> odd_edges(const std::vector<CubeRecord>& cubes) {
    std::vector<OpenEdge> edges;
    for (const CubeRecord& cube : cubes)
        for (size_t t = 0; t < cube.triangles.size(); t += 3)
            for (int c = 0; c < 3; ++c) {
                const PositionBits a = position_bits(&cube.positions[3 * size_t(cube.triangles[t + c])]);
                const PositionBits b = position_bits(&cube.positions[3 * size_t(cube.triangles[t + (c + 1) % 3])]);
                edges.push_back(a < b ? OpenEdge{a, b} : OpenEdge{b, a});
            }
    std::sort(edges.begin(), edges.end());
    return keep_odd(edges);
}

void mark_boundary(std::vector<CubeRecord>& cubes, std::vector<OpenEdge> listed) {
    std::sort(listed.begin(), listed.end());
    std::vector<PositionBits> points;
    for (const OpenEdge& e : keep_odd(listed)) points.push_back(e.a), points.push_back(e.b);
    std::sort(points.begin(), points.end());
    points.erase(std::unique(points.begin(), points.end()), points.end());
    for (CubeRecord& cube : cubes) {
        std::vector<uint8_t> flags(cube.vertex_count());
        for (uint32_t v = 0; v < cube.vertex_count(); ++v)
            flags[v] = std::binary_search(points.begin(), points.end(), position_bits(&cube.positions[3 * size_t(v)]));
        if (std::find(flags.begin(), flags.end(), 1) != flags.end()) cube.boundary = std::move(flags);
    }
}

}  // namespace strata::build
