#include "preprocess/ring_seam.h"

#include <algorithm>
#include <map>
#include <set>

namespace strata {

namespace {

struct Sample {
    int64_t x, y;
    auto operator<=>(const Sample&) const = default;
};

}  // namespace

std::vector<std::vector<BorderStep>> zone_border(const CellCovers& zone, int64_t columns, int64_t rows) {
    // The zone's finest cells.
    std::set<Sample> cells;
    for_each_finest_cell(zone, columns, rows, [&](int64_t x, int64_t y) { cells.insert({x, y}); });
    // Its border's directed edges, the zone on their left, each with the cell beyond it.
    struct Edge {
        Sample to, outside;
    };
    std::map<Sample, std::vector<Edge>> from;
    for (const Sample& c : cells) {
        const auto side = [&](Sample a, Sample b, Sample beyond) {
            if (!cells.count(beyond)) from[a].push_back({b, beyond});
        };
        side({c.x, c.y}, {c.x + 1, c.y}, {c.x, c.y - 1});
        side({c.x + 1, c.y}, {c.x + 1, c.y + 1}, {c.x + 1, c.y});
        side({c.x + 1, c.y + 1}, {c.x, c.y + 1}, {c.x, c.y + 1});
        side({c.x, c.y + 1}, {c.x, c.y}, {c.x - 1, c.y});
    }
    // Chained from the lowest sample left; where two loops touch at a corner, each turns right there,
    // around its own cells.
    std::vector<std::vector<BorderStep>> loops;
    while (!from.empty()) {
        Sample at = from.begin()->first;
        std::vector<BorderStep> loop;
        Sample heading{0, 0};
        while (true) {
            auto out = from.find(at);
            if (out == from.end()) break;
            std::vector<Edge>& edges = out->second;
            size_t pick = 0;
            for (size_t e = 1; e < edges.size(); ++e) {
                const Sample d{edges[e].to.x - at.x, edges[e].to.y - at.y};
                if (heading.x * d.y - heading.y * d.x < 0) pick = e;  // a right turn
            }
            const Edge edge = edges[pick];
            edges.erase(edges.begin() + std::ptrdiff_t(pick));
            if (edges.empty()) from.erase(out);
            const bool inside_raster = edge.outside.x >= 0 && edge.outside.y >= 0 && edge.outside.x < columns - 1 && edge.outside.y < rows - 1;
            loop.push_back({at.x, at.y, inside_raster ? edge.outside.x : -1, inside_raster ? edge.outside.y : -1});
            heading = {edge.to.x - at.x, edge.to.y - at.y};
            at = edge.to;
        }
        loops.push_back(std::move(loop));
    }
    return loops;
}

void ring_seam_step(std::span<const BorderStep> loop, size_t i, uint32_t level, uint32_t finest, int64_t columns, int64_t rows,
                    std::vector<std::array<SeamVertex, 3>>& out) {
    const BorderStep& step = loop[i];
    if (!step.seamed()) return;
    const size_t n = loop.size();
    const BorderStep& next = loop[(i + 1) % n];
    const int64_t size = int64_t(1) << (finest - level);
    // The step runs along a row or a column; t is the position along it. The level's samples there
    // are the multiples of its cell size, and the raster's last one (terrain_pyramid.h).
    const bool along_row = next.row == step.row;
    const int64_t t0 = along_row ? step.column : step.row, t1 = along_row ? next.column : next.row;
    const int64_t low = std::min(t0, t1) / size * size, high = std::min(low + size, (along_row ? columns : rows) - 1);
    const int64_t start = t1 > t0 ? low : high, end = t1 > t0 ? high : low;
    auto grid = [&](int64_t t) { return SeamVertex{true, along_row ? t : step.column, along_row ? step.row : t, level, 0}; };
    const SeamVertex g0 = grid(start), here{false, step.column, step.row, 0, uint32_t(i)},
                     there{false, next.column, next.row, 0, uint32_t((i + 1) % n)};
    out.push_back({g0, there, here});
    if (t1 == end) out.push_back({g0, grid(end), there});
}

std::vector<std::array<SeamVertex, 3>> ring_seam(std::span<const BorderStep> loop, std::span<const uint32_t> levels, uint32_t finest,
                                                 int64_t columns, int64_t rows) {
    std::vector<std::array<SeamVertex, 3>> triangles;
    for (size_t i = 0; i < loop.size(); ++i) ring_seam_step(loop, i, levels[i], finest, columns, rows, triangles);
    return triangles;
}

}  // namespace strata
