// The crack check's CPU side (DESIGN.md §6): a view's drawn triangles as the CPU twin of the morph
// places them, welded by exact float position, and the edges used an odd number of times.
#pragma once

#include <algorithm>
#include <array>
#include <cstring>
#include <optional>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "nodes/hlod_model.h"

namespace strata::test {

using Position = std::array<uint32_t, 3>;  // a morphed position's float bits: welds exactly

inline Position bits(const glm::vec3& p) {
    Position out;
    std::memcpy(out.data(), &p, sizeof out);
    return out;
}

// The drawn triangles of a view from `eye` (lattice frame) as morphed positions, measured from the
// eye as the renderer measures them, or from `frame` to compare two views; degenerate ones dropped.
inline std::vector<std::array<Position, 3>> drawn_triangles(const HlodModel& model, const std::vector<uint32_t>& cubes,
                                                     const glm::dvec3& eye, const CubeKappas& kappa,
                                                     const std::optional<glm::dvec3>& frame = std::nullopt) {
    std::vector<std::array<Position, 3>> triangles;
    std::vector<glm::vec3> positions;
    const HlodModel::LatticeAnchor anchor = model.anchor_at(eye, frame.value_or(eye));
    for (uint32_t c : cubes) {
        model.morphed_positions(c, anchor, kappa, positions);
        const auto& indices = model.cubes()[c].data->indices;
        for (size_t t = 0; t < indices.size(); t += 3) {
            std::array<Position, 3> tri{bits(positions[indices[t]]), bits(positions[indices[t + 1]]),
                                        bits(positions[indices[t + 2]])};
            if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
            triangles.push_back(tri);
        }
    }
    return triangles;
}

// Edges (undirected, welded by position) used an odd number of times: cracks in a closed surface.
inline std::vector<std::pair<Position, Position>> odd_edge_list(const std::vector<std::array<Position, 3>>& triangles) {
    std::vector<std::pair<Position, Position>> edges, odd;
    for (const auto& t : triangles)
        for (int e = 0; e < 3; ++e) edges.push_back(std::minmax(t[e], t[(e + 1) % 3]));
    std::sort(edges.begin(), edges.end());
    for (size_t i = 0, j; i < edges.size(); i = j) {
        for (j = i; j < edges.size() && edges[j] == edges[i]; ++j) {
        }
        if ((j - i) % 2) odd.push_back(edges[i]);
    }
    return odd;
}
inline size_t odd_edges(const std::vector<std::array<Position, 3>>& triangles) { return odd_edge_list(triangles).size(); }

}  // namespace strata::test
