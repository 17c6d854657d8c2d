#include "preprocess/footprint.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

namespace strata {

namespace {

using Wide = WideInt;

// Lattice points stay within ±2^(30 + kGridPointBits): products of two coordinate differences fit
// 2^102 and an area sums 2^25 of them inside 128 bits.
constexpr double kLargestCell = double(int64_t(1) << 30);

std::string where(const GridPoint& p) {
    char text[96];
    std::snprintf(text, sizeof text, "column %.3f, row %.3f", double(p.x) / double(kGridPointOne), double(p.y) / double(kGridPointOne));
    return text;
}

// Twice the signed area enclosed by `points` (a closed ring), in lattice units squared.
Wide twice_area(const std::vector<GridPoint>& points) {
    Wide sum = 0;
    const GridPoint o = points.front();
    for (size_t i = 0; i < points.size(); ++i) {
        const GridPoint& a = points[i];
        const GridPoint& b = points[(i + 1) % points.size()];
        sum += Wide(a.x - o.x) * Wide(b.y - o.y) - Wide(b.x - o.x) * Wide(a.y - o.y);
    }
    return sum;
}

// c on the closed segment a–b, given that the three are collinear.
bool within(GridPoint a, GridPoint b, GridPoint c) {
    return std::min(a.x, b.x) <= c.x && c.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= c.y && c.y <= std::max(a.y, b.y);
}

// Whether the closed segments a–b and c–d share a point.
bool segments_meet(GridPoint a, GridPoint b, GridPoint c, GridPoint d) {
    const int o1 = orientation(a, b, c), o2 = orientation(a, b, d), o3 = orientation(c, d, a), o4 = orientation(c, d, b);
    if (o1 != o2 && o3 != o4 && o1 * o2 <= 0 && o3 * o4 <= 0) return true;
    return (o1 == 0 && within(a, b, c)) || (o2 == 0 && within(a, b, d)) || (o3 == 0 && within(c, d, a)) || (o4 == 0 && within(c, d, b));
}

}  // namespace

// Edges are bucketed by the cells they touch, so the pairs tested are those near each other.
void check_ring_simple(const std::vector<GridPoint>& ring, std::string_view what) {
    const size_t n = ring.size();
    double length = 0;
    for (size_t i = 0; i < n; ++i) {
        const GridPoint a = ring[i], b = ring[(i + 1) % n];
        if (a == b) throw InputError(std::string(what) + ": two boundary vertices fall on the same point of the grid (" + where(a) + ")");
        length += std::max(std::abs(double(b.x - a.x)), std::abs(double(b.y - a.y)));
    }
    int64_t bucket = 1;  // in lattice steps: about the mean edge length, a power of two
    while (double(bucket) * double(n) < length && bucket < (int64_t(1) << 50)) bucket *= 2;
    std::unordered_map<uint64_t, std::vector<uint32_t>> edges_in;
    for (size_t i = 0; i < n; ++i)
        squares_touched(ring[i], ring[(i + 1) % n], bucket, [&](int64_t x, int64_t y) {
            edges_in[uint64_t(x) * 0x9E3779B97F4A7C15ull ^ uint64_t(y)].push_back(uint32_t(i));  // a clash only adds pairs
        });
    for (const auto& [cell, edges] : edges_in)
        for (size_t u = 0; u < edges.size(); ++u)
            for (size_t v = u + 1; v < edges.size(); ++v) {
                size_t i = edges[u], j = edges[v];
                if (i > j) std::swap(i, j);
                const GridPoint a = ring[i], b = ring[(i + 1) % n], c = ring[j], d = ring[(j + 1) % n];
                bool meet;
                if (j == i + 1) meet = orientation(a, b, d) == 0 && (within(a, b, d) || within(c, d, a));  // folds back
                else if (i == 0 && j == n - 1) meet = orientation(c, d, b) == 0 && (within(c, d, b) || within(a, b, c));
                else meet = segments_meet(a, b, c, d);
                if (meet)
                    throw InputError(std::string(what) + ": the boundary crosses or touches itself near " + where(a) +
                                     " (boundary edges " + std::to_string(i) + " and " + std::to_string(j) + ")");
            }
}

GridPoint to_grid_point(glm::dvec2 p) {
    if (!(std::abs(p.x) <= kLargestCell && std::abs(p.y) <= kLargestCell))
        throw std::runtime_error("a point lies 2^30 cells or more from the raster (or is not a number)");
    return {std::llround(p.x * double(kGridPointOne)), std::llround(p.y * double(kGridPointOne))};
}

int orientation(GridPoint a, GridPoint b, GridPoint c) {
    const Wide cross = Wide(b.x - a.x) * Wide(c.y - a.y) - Wide(b.y - a.y) * Wide(c.x - a.x);
    return (cross > 0) - (cross < 0);
}

void cells_touched(GridPoint a, GridPoint b, int64_t cell_size, const std::function<void(int64_t, int64_t)>& visit) {
    squares_touched(a, b, cell_size * kGridPointOne, visit);
}

void squares_touched(GridPoint a, GridPoint b, int64_t side, const std::function<void(int64_t, int64_t)>& visit) {
    const Wide unit = side;
    if (b.x < a.x) std::swap(a, b);
    const Wide dx = b.x - a.x, dy = b.y - a.y;
    const int64_t first = int64_t(ceil_div(a.x, unit) - 1), last = int64_t(floor_div(b.x, unit));
    for (int64_t column = first; column <= last; ++column) {
        const Wide x0 = std::max<Wide>(a.x, column * unit), x1 = std::min<Wide>(b.x, (column + 1) * unit);
        if (x0 > x1) continue;
        // y at x0 and x1 as fractions over dx (or the segment's own ends when it is vertical).
        Wide n0 = a.y, n1 = b.y, d = 1;
        if (dx != 0) {
            n0 = Wide(a.y) * dx + (x0 - a.x) * dy;
            n1 = Wide(a.y) * dx + (x1 - a.x) * dy;
            d = dx;
        }
        const Wide lo = std::min(n0, n1), hi = std::max(n0, n1);
        const int64_t row_first = int64_t(ceil_div(lo, d * unit) - 1), row_last = int64_t(floor_div(hi, d * unit));
        for (int64_t row = row_first; row <= row_last; ++row) {
            // Closed squares: the row above lo's line is met only when lo lies on it or below.
            if (Wide(row + 1) * unit * d < lo || Wide(row) * unit * d > hi) continue;
            visit(column, row);
        }
    }
}

std::vector<std::vector<uint32_t>> boundary_loops(const Mesh& mesh, std::string_view what) {
    // Weld by exact position.
    const size_t vertices = mesh.vertex_count();
    std::vector<uint32_t> weld(vertices);
    std::unordered_map<std::string, uint32_t> first_at;
    first_at.reserve(vertices);
    for (size_t v = 0; v < vertices; ++v) {
        const std::string key(reinterpret_cast<const char*>(&mesh.positions[3 * v]), 3 * sizeof(float));
        weld[v] = first_at.try_emplace(key, uint32_t(v)).first->second;
    }
    // Edges used once, in the direction their triangle runs.
    std::unordered_map<uint64_t, int> uses;  // undirected edge → uses; a lone use keeps its direction
    std::unordered_map<uint64_t, uint64_t> directed;
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const uint32_t c[3] = {weld[mesh.indices[t]], weld[mesh.indices[t + 1]], weld[mesh.indices[t + 2]]};
        if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0]) continue;
        for (int e = 0; e < 3; ++e) {
            const uint32_t from = c[e], to = c[(e + 1) % 3];
            const uint64_t key = (uint64_t(std::min(from, to)) << 32) | std::max(from, to);
            ++uses[key];
            directed[key] = (uint64_t(from) << 32) | to;
        }
    }
    std::unordered_map<uint32_t, uint32_t> next;
    for (const auto& [key, count] : uses) {
        if (count != 1) continue;
        const uint64_t edge = directed[key];
        const uint32_t from = uint32_t(edge >> 32), to = uint32_t(edge);
        if (!next.emplace(from, to).second) {
            const float* p = &mesh.positions[3 * size_t(from)];
            throw InputError(std::string(what) + ": boundary vertex " + std::to_string(from) + " at (" + std::to_string(p[0]) + ", " +
                             std::to_string(p[1]) + ", " + std::to_string(p[2]) +
                             ") starts two boundary edges (two boundary loops touch there): its footprint is ambiguous");
        }
    }
    // Chain them, from the lowest vertex of each loop (a deterministic start).
    std::vector<uint32_t> starts;
    for (const auto& [from, to] : next) starts.push_back(from);
    std::sort(starts.begin(), starts.end());
    std::vector<std::vector<uint32_t>> loops;
    std::unordered_map<uint32_t, bool> done;
    for (const uint32_t start : starts) {
        if (done[start]) continue;
        std::vector<uint32_t> loop;
        for (uint32_t v = start; !done[v];) {
            done[v] = true;
            loop.push_back(v);
            const auto it = next.find(v);
            if (it == next.end()) throw InputError(std::string(what) + ": a boundary does not close into a loop");
            v = it->second;
        }
        loops.push_back(std::move(loop));
    }
    return loops;
}

Footprint make_footprint(const Mesh& mesh, const std::function<glm::dvec2(const glm::dvec3&)>& to_grid, int64_t columns,
                         int64_t rows, std::string_view what) {
    const std::vector<std::vector<uint32_t>> loops = boundary_loops(mesh, what);
    if (loops.empty())
        throw InputError(std::string(what) + ": the mesh has no open boundary (a closed surface): there is no ring to stitch the terrain to");
    const GridPoint corner = to_grid_point(glm::dvec2(columns - 1, rows - 1));
    std::vector<std::vector<GridPoint>> rings;
    for (const std::vector<uint32_t>& loop : loops) {
        std::vector<GridPoint> ring;
        ring.reserve(loop.size());
        for (const uint32_t v : loop) {
            const float* p = &mesh.positions[3 * size_t(v)];
            const glm::dvec3 position(mesh.origin[0] + double(p[0]), mesh.origin[1] + double(p[1]), mesh.origin[2] + double(p[2]));
            GridPoint g;
            try {
                g = to_grid_point(to_grid(position));
            } catch (const std::runtime_error& e) {
                throw InputError(std::string(what) + ": boundary vertex " + std::to_string(v) + ": " + e.what());
            }
            ring.push_back(g);
        }
        rings.push_back(std::move(ring));
    }
    size_t outer = 0;
    std::vector<Wide> areas;
    for (size_t i = 0; i < rings.size(); ++i) {
        const Wide a = twice_area(rings[i]);
        areas.push_back(a < 0 ? -a : a);
        if (areas[i] > areas[outer]) outer = i;
    }
    Footprint footprint;
    footprint.ring = loops[outer];
    footprint.points = rings[outer];
    if (areas[outer] == 0 || footprint.points.size() < 3)
        throw InputError(std::string(what) + ": the mesh's boundary encloses no area on the ground (seen from above it is a line or a point)");
    if (twice_area(footprint.points) < 0) {
        std::reverse(footprint.ring.begin(), footprint.ring.end());
        std::reverse(footprint.points.begin(), footprint.points.end());
    }
    for (const GridPoint& p : footprint.points)
        if (p.x < 0 || p.y < 0 || p.x > corner.x || p.y > corner.y)
            throw InputError(std::string(what) + ": the mesh reaches outside the terrain's raster (a boundary vertex at " + where(p) +
                             ", the raster has " + std::to_string(columns) + " columns and " + std::to_string(rows) + " rows)");
    check_ring_simple(footprint.points, what);
    for (size_t i = 0; i < rings.size(); ++i) {
        if (i == outer) continue;
        if (!ring_contains(footprint.points, rings[i].front()))
            throw InputError(std::string(what) + ": the mesh has separate pieces (a boundary loop lies outside the outer one, near " +
                             where(rings[i].front()) + "): embed each piece on its own");
        ++footprint.inner_loops;
    }
    return footprint;
}

bool ring_contains(const std::vector<GridPoint>& ring, GridPoint p) {
    bool in = false;
    for (size_t i = 0; i < ring.size(); ++i) {
        GridPoint a = ring[i], b = ring[(i + 1) % ring.size()];
        if ((a.y > p.y) == (b.y > p.y)) continue;
        if (a.y > b.y) std::swap(a, b);
        if (orientation(a, b, p) > 0) in = !in;  // p left of the upward edge: the edge lies right of p
    }
    return in;
}

std::pair<GridPoint, GridPoint> bounds(const std::vector<GridPoint>& points) {
    GridPoint lo = points.front(), hi = lo;
    for (const GridPoint& p : points) {
        lo = {std::min(lo.x, p.x), std::min(lo.y, p.y)};
        hi = {std::max(hi.x, p.x), std::max(hi.y, p.y)};
    }
    return {lo, hi};
}

void for_each_finest_cell(const CellCovers& covers, int64_t columns, int64_t rows, const std::function<void(int64_t, int64_t)>& visit) {
    for (int64_t cy = covers.first_y; cy < covers.first_y + covers.height; ++cy)
        for (int64_t cx = covers.first_x; cx < covers.first_x + covers.width; ++cx) {
            if (covers.at(cx, cy) == CellCover::none) continue;
            for (int64_t y = cy * covers.size; y < std::min((cy + 1) * covers.size, rows - 1); ++y)
                for (int64_t x = cx * covers.size; x < std::min((cx + 1) * covers.size, columns - 1); ++x) visit(x, y);
        }
}

CellCovers classify_cells(const std::vector<GridPoint>& ring, int64_t cell_size, int64_t columns, int64_t rows) {
    const int64_t unit = cell_size * kGridPointOne;
    const int64_t cells_x = std::max<int64_t>(1, (columns - 1 + cell_size - 1) / cell_size);
    const int64_t cells_y = std::max<int64_t>(1, (rows - 1 + cell_size - 1) / cell_size);
    const auto [lo, hi] = bounds(ring);
    CellCovers covers;
    covers.size = cell_size;
    covers.first_x = std::max<int64_t>(0, int64_t(ceil_div(lo.x, unit)) - 1);
    covers.first_y = std::max<int64_t>(0, int64_t(ceil_div(lo.y, unit)) - 1);
    covers.width = std::min<int64_t>(cells_x, int64_t(floor_div(hi.x, unit)) + 1) - covers.first_x;
    covers.height = std::min<int64_t>(cells_y, int64_t(floor_div(hi.y, unit)) + 1) - covers.first_y;
    covers.cover.assign(size_t(covers.width * covers.height), CellCover::none);
    const size_t n = ring.size();
    for (size_t i = 0; i < n; ++i)
        cells_touched(ring[i], ring[(i + 1) % n], cell_size, [&](int64_t x, int64_t y) {
            if (x >= covers.first_x && y >= covers.first_y && x < covers.first_x + covers.width && y < covers.first_y + covers.height)
                covers.cover[size_t((y - covers.first_y) * covers.width + (x - covers.first_x))] = CellCover::partly;
        });
    // The other cells lie wholly inside or outside: a scanline through each row, just above its lower
    // line, counts the ring's crossings left of each cell (those fall in PC cells only).
    std::vector<std::vector<uint32_t>> edges_by_row(size_t(covers.height));
    for (size_t i = 0; i < n; ++i) {
        const GridPoint a = ring[i], b = ring[(i + 1) % n];
        const int64_t first = std::max<int64_t>(covers.first_y, int64_t(floor_div(std::min(a.y, b.y), unit)));
        const int64_t last = std::min<int64_t>(covers.first_y + covers.height - 1, int64_t(floor_div(std::max(a.y, b.y), unit)));
        for (int64_t row = first; row <= last; ++row) edges_by_row[size_t(row - covers.first_y)].push_back(uint32_t(i));
    }
    std::vector<int64_t> crossings;
    for (int64_t row = covers.first_y; row < covers.first_y + covers.height; ++row) {
        const int64_t y = row * unit + 1;
        crossings.clear();
        for (const uint32_t i : edges_by_row[size_t(row - covers.first_y)]) {
            GridPoint a = ring[i], b = ring[(i + 1) % n];
            if ((a.y > y) == (b.y > y)) continue;
            if (a.y > b.y) std::swap(a, b);
            // The crossing's cell column: floor(x / unit), x = a.x + (y − a.y)(b.x − a.x)/(b.y − a.y).
            const Wide numerator = Wide(a.x) * (b.y - a.y) + Wide(y - a.y) * (b.x - a.x);
            crossings.push_back(int64_t(floor_div(numerator, Wide(b.y - a.y) * unit)));
        }
        std::sort(crossings.begin(), crossings.end());
        size_t left = 0;
        for (int64_t x = covers.first_x; x < covers.first_x + covers.width; ++x) {
            while (left < crossings.size() && crossings[left] < x) ++left;
            CellCover& cover = covers.cover[size_t((row - covers.first_y) * covers.width + (x - covers.first_x))];
            if (cover == CellCover::none && left % 2 == 1) cover = CellCover::whole;
        }
    }
    return covers;
}

}  // namespace strata
