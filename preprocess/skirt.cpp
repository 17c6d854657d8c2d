#include "preprocess/skirt.h"

#include <algorithm>
#include <map>
#include <optional>

namespace strata {

namespace {

constexpr int64_t kOne = kGridPointOne;

struct Cell {
    int64_t x, y;
    auto operator<=>(const Cell&) const = default;
};

// A stretch of the ring inside one finest cell: skirt vertices in ring order, the first where the ring
// enters the cell, the last where it leaves (both on the cell's border).
struct Piece {
    std::vector<uint32_t> points;
};

// The ring moved off every grid line and corner by a lattice step or two (a millionth of a cell), east
// and north as half-open cells count a point on a line: a vertex on a line, an edge along one or through
// a grid corner would make zero-width polygons, which ear clipping cannot tell from folds. The skirt's
// triangles still name the ring's own vertices; only where they are cut moves, by far less than the
// lattice the mesh is drawn on.
std::vector<GridPoint> off_the_grid_lines(std::vector<GridPoint> ring, std::string_view what) {
    const size_t n = ring.size();
    for (int round = 0; round < 8; ++round) {
        bool moved = false;
        for (GridPoint& p : ring) {
            if (p.x % kOne == 0) ++p.x, moved = true;
            if (p.y % kOne == 0) ++p.y, moved = true;
        }
        for (size_t e = 0; e < n; ++e) {  // an edge through a grid corner: move its first end east
            GridPoint& a = ring[e];
            const GridPoint b = ring[(e + 1) % n];
            const int64_t x_lo = std::min(a.x, b.x), x_hi = std::max(a.x, b.x);
            for (int64_t k = int64_t(floor_div(x_lo, kOne)) + 1; k <= int64_t(floor_div(x_hi, kOne)); ++k) {
                const WideInt dx = WideInt(b.x) - a.x, num = WideInt(b.y - a.y) * (WideInt(k) * kOne - a.x);
                if (num % dx == 0 && (WideInt(a.y) + num / dx) % kOne == 0) {
                    a.x += 2;
                    moved = true;
                    break;
                }
            }
        }
        if (!moved) {
            check_ring_simple(ring, what);
            return ring;
        }
    }
    throw InputError(std::string(what) + ": the boundary cannot be moved off the grid lines by a millionth of a cell (its vertices crowd one another)");
}

class SkirtBuilder {
public:
    SkirtBuilder(const Footprint& footprint, int64_t columns, int64_t rows, const std::string& what)
        : ring_(off_the_grid_lines(footprint.points, what)), columns_(columns), rows_(rows), what_(what) {}

    Skirt build(const CellCovers& zone);

private:
    uint32_t sample(int64_t c, int64_t r);
    void split_ring();
    void grid_cell(Cell cell);
    void cut_cell(Cell cell, const std::vector<Piece>& pieces);
    void holed_cell(Cell cell);
    void ear_clip(std::vector<uint32_t> polygon, Cell cell);
    long double perimeter_at(Cell cell, uint32_t vertex) const;
    [[noreturn]] void fail(Cell cell, const std::string& why) const;

    const std::vector<GridPoint> ring_;
    int64_t columns_, rows_;
    const std::string& what_;
    Skirt skirt_;
    std::map<std::pair<int64_t, int64_t>, uint32_t> samples_;
    std::map<Cell, std::vector<Piece>> pieces_;
    std::optional<Cell> holed_;  // the cell the whole ring lies in, when it crosses no grid line
};

uint32_t SkirtBuilder::sample(int64_t c, int64_t r) {
    const auto [it, added] = samples_.try_emplace({c, r}, uint32_t(skirt_.vertices.size()));
    if (added) skirt_.vertices.push_back({SkirtVertex::Kind::sample, c, r, {c * kOne, r * kOne}});
    return it->second;
}

// The half-open cell of one axis holding the open stretch of edge a → b between parameters t0 < t1
// (each num/den): the floor of its lower end, or of the coordinate itself when it is constant.
int64_t stretch_cell(int64_t a, int64_t b, WideInt n0, WideInt d0, WideInt n1, WideInt d1) {
    const WideInt delta = WideInt(b) - a;
    if (delta == 0) return int64_t(floor_div(a, kOne));
    const bool rising = delta > 0;
    const WideInt n = rising ? n0 : n1, d = rising ? d0 : d1;
    return int64_t(floor_div(WideInt(a) * d + delta * n, d * kOne));
}

// Splits every ring edge where it crosses a grid line (a point on the line counts as east or north of
// it), and files each stretch between crossings under its cell, consecutive stretches in one cell as one
// piece.
void SkirtBuilder::split_ring() {
    const size_t n = ring_.size();
    for (size_t i = 0; i < n; ++i) skirt_.vertices.push_back({SkirtVertex::Kind::boundary, int64_t(i), 0, ring_[i]});
    skirt_.crossings.assign(n, {});
    struct Stretch {
        Cell cell;
        uint32_t from, to;
    };
    std::vector<Stretch> stretches;
    for (size_t e = 0; e < n; ++e) {
        const GridPoint a = ring_[e], b = ring_[(e + 1) % n];
        std::vector<std::pair<WideInt, WideInt>> ts;  // crossing parameters num/den, den > 0
        auto lines = [&](int64_t from, int64_t to) {
            if (from == to) return;
            const int64_t lo = std::min(from, to), hi = std::max(from, to);
            const WideInt den = WideInt(to) - from;
            for (int64_t k = int64_t(floor_div(lo, kOne)) + 1; k <= int64_t(floor_div(hi, kOne)); ++k) {
                WideInt num = WideInt(k) * kOne - from, d = den;
                if (d < 0) num = -num, d = -d;
                if (num > 0 && num < d) ts.emplace_back(num, d);  // the ends are the ring's own vertices
            }
        };
        lines(a.x, b.x);
        lines(a.y, b.y);
        std::sort(ts.begin(), ts.end(), [](const auto& p, const auto& q) { return p.first * q.second < q.first * p.second; });
        ts.erase(std::unique(ts.begin(), ts.end(), [](const auto& p, const auto& q) { return p.first * q.second == q.first * p.second; }),
                 ts.end());
        uint32_t from = uint32_t(e);
        WideInt n0 = 0, d0 = 1;
        for (size_t k = 0; k <= ts.size(); ++k) {
            const WideInt n1 = k < ts.size() ? ts[k].first : 1, d1 = k < ts.size() ? ts[k].second : 1;
            uint32_t to = uint32_t((e + 1) % n);
            if (k < ts.size()) {
                // Rounded to the lattice; exact on its grid line (the one it crosses is a multiple of kOne),
                // and off every other grid line (a rounding onto one would put it on a grid corner).
                const auto at = [&](int64_t p, int64_t q) {
                    const WideInt exact = WideInt(p) * d1 + (WideInt(q) - p) * n1;  // the coordinate times d1
                    int64_t rounded = int64_t(floor_div(2 * exact + d1, 2 * d1));
                    if (rounded % kOne == 0 && exact != WideInt(rounded) * d1) rounded += exact > WideInt(rounded) * d1 ? 1 : -1;
                    return rounded;
                };
                to = uint32_t(skirt_.vertices.size());
                skirt_.vertices.push_back({SkirtVertex::Kind::crossing, int64_t(e), 0, {at(a.x, b.x), at(a.y, b.y)}, int64_t(n1), int64_t(d1)});
                skirt_.crossings[e].push_back(to);
            }
            stretches.push_back({{stretch_cell(a.x, b.x, n0, d0, n1, d1), stretch_cell(a.y, b.y, n0, d0, n1, d1)}, from, to});
            from = to, n0 = n1, d0 = d1;
        }
    }
    // Pieces: runs of stretches in one cell, starting where the previous stretch is in another cell.
    size_t start = 0;
    while (start < stretches.size() && stretches[start].cell == stretches[(start + stretches.size() - 1) % stretches.size()].cell)
        ++start;
    if (start == stretches.size()) {  // a mesh smaller than a cell: the ring never leaves it
        holed_ = stretches[0].cell;
        return;
    }
    for (size_t k = 0; k < stretches.size();) {
        const Stretch& first = stretches[(start + k) % stretches.size()];
        Piece piece{{first.from}};
        while (k < stretches.size() && stretches[(start + k) % stretches.size()].cell == first.cell)
            piece.points.push_back(stretches[(start + k++) % stretches.size()].to);
        pieces_[first.cell].push_back(std::move(piece));
    }
}

// The grid's two triangles, split along the diagonal from the cell's lower corner to its upper one as the
// terrain's cells are (terrain_pyramid.h), counter-clockwise in raster space.
void SkirtBuilder::grid_cell(Cell cell) {
    const uint32_t lo = sample(cell.x, cell.y), hi = sample(cell.x + 1, cell.y + 1);
    const uint32_t right = sample(cell.x + 1, cell.y), up = sample(cell.x, cell.y + 1);
    skirt_.triangles.insert(skirt_.triangles.end(), {lo, right, hi, lo, hi, up});
}

// Where a point on a cell's border lies along it, counter-clockwise from the lower corner: 0 … 4 (cell
// sides), from the point's exact position: two crossings a lattice step apart (the ring poking out of the
// cell and back) round to one lattice point, but their order along the side decides the polygons.
long double SkirtBuilder::perimeter_at(Cell cell, uint32_t vertex) const {
    const SkirtVertex& p = skirt_.vertices[vertex];
    long double x = (long double)(p.at.x - cell.x * kOne) / kOne, y = (long double)(p.at.y - cell.y * kOne) / kOne;
    if (p.kind == SkirtVertex::Kind::crossing) {
        const GridPoint a = ring_[size_t(p.a)], b = ring_[(size_t(p.a) + 1) % ring_.size()];
        auto exact = [&](int64_t from, int64_t to, int64_t corner) {
            const WideInt num = (WideInt(from) - corner) * p.den + (WideInt(to) - from) * p.num;
            return (long double)num / (long double)p.den / (long double)kOne;
        };
        if (p.at.x % kOne != 0) x = exact(a.x, b.x, cell.x * kOne);  // on a horizontal line: x varies
        if (p.at.y % kOne != 0) y = exact(a.y, b.y, cell.y * kOne);
    }
    if (y == 0 && x < 1) return x;
    if (x == 1 && y < 1) return 1 + y;
    if (y == 1 && x > 0) return 2 + (1 - x);
    return 3 + (1 - y);
}

// The polygons of the cell outside the footprint. The ring runs counter-clockwise around the footprint,
// so a piece walked backwards has the ground on its left; from where it entered the cell, the ground
// continues counter-clockwise along the cell's border to where the next piece leaves it.
void SkirtBuilder::cut_cell(Cell cell, const std::vector<Piece>& pieces) {
    ++skirt_.cut_cells;
    std::vector<long double> entry, exit;
    for (const Piece& piece : pieces) {
        entry.push_back(perimeter_at(cell, piece.points.front()));
        exit.push_back(perimeter_at(cell, piece.points.back()));
    }
    const uint32_t corners[4] = {sample(cell.x, cell.y), sample(cell.x + 1, cell.y), sample(cell.x + 1, cell.y + 1), sample(cell.x, cell.y + 1)};
    auto ahead_of = [](long double from, long double to) { return to >= from ? to - from : to - from + 4; };
    std::vector<bool> used(pieces.size(), false);
    for (size_t first = 0; first < pieces.size(); ++first) {
        if (used[first]) continue;
        std::vector<uint32_t> polygon;
        size_t piece = first;
        do {
            if (used[piece]) fail(cell, "the boundary's pieces in it do not close into polygons");
            used[piece] = true;
            polygon.insert(polygon.end(), pieces[piece].points.rbegin(), pieces[piece].points.rend());
            // The nearest exit counter-clockwise from this entry.
            const long double from = entry[piece];
            size_t next = pieces.size();
            long double best = 0;
            for (size_t q = 0; q < pieces.size(); ++q) {
                const long double ahead = ahead_of(from, exit[q]);
                if (ahead == 0) fail(cell, "the boundary leaves it where it enters it");
                if (next == pieces.size() || ahead < best) next = q, best = ahead;
            }
            std::vector<std::pair<long double, uint32_t>> passed;  // the corners on the way
            for (int k = 0; k < 4; ++k)
                if (const long double ahead = ahead_of(from, k); ahead < best && ahead > 0) passed.emplace_back(ahead, corners[k]);
            std::sort(passed.begin(), passed.end());
            for (const auto& [ahead, corner] : passed) polygon.push_back(corner);
            piece = next;
        } while (piece != first);
        ear_clip(std::move(polygon), cell);
    }
}

// A cell the whole ring lies in (a mesh smaller than a raster cell): the cell less the footprint, as the
// two triangles from the cell's west side to the ring's westmost vertex and from its east side to the
// eastmost one (no ring vertex lies west of the first or east of the second, and none on a grid line,
// so they hold none), and the two simple polygons those cuts leave below and above the ring.
void SkirtBuilder::holed_cell(Cell cell) {
    ++skirt_.cut_cells;
    const size_t n = ring_.size();
    size_t west = 0, east = 0;
    for (size_t i = 1; i < n; ++i) {
        if (ring_[i].x < ring_[west].x) west = i;
        if (ring_[i].x > ring_[east].x) east = i;
    }
    const uint32_t lower_left = sample(cell.x, cell.y), lower_right = sample(cell.x + 1, cell.y);
    const uint32_t upper_right = sample(cell.x + 1, cell.y + 1), upper_left = sample(cell.x, cell.y + 1);
    skirt_.triangles.insert(skirt_.triangles.end(), {lower_left, uint32_t(west), upper_left, lower_right, upper_right, uint32_t(east)});
    // The ring runs counter-clockwise: eastward along its bottom, westward along its top; each polygon
    // walks its part backwards, the ground on its left.
    auto backwards = [&](std::vector<uint32_t> polygon, size_t from, size_t to) {
        for (size_t i = from;; i = (i + n - 1) % n) {
            polygon.push_back(uint32_t(i));
            if (i == to) break;
        }
        ear_clip(std::move(polygon), cell);
    };
    backwards({lower_left, lower_right}, east, west);
    backwards({upper_right, upper_left}, west, east);
}

// Ear clipping on the lattice, exact: an ear is a convex corner whose closed triangle holds no other
// vertex of the polygon (one on its far side would be a T-junction); a polygon left with only flat
// corners (a zero-width strip along a grid line) is closed with zero-area triangles, which keep it
// watertight.
void SkirtBuilder::ear_clip(std::vector<uint32_t> polygon, Cell cell) {
    const auto& v = skirt_.vertices;
    polygon.erase(std::unique(polygon.begin(), polygon.end()), polygon.end());
    while (polygon.size() > 1 && polygon.front() == polygon.back()) polygon.pop_back();
    auto contains = [&](GridPoint a, GridPoint b, GridPoint c, GridPoint p) {
        return orientation(a, b, p) >= 0 && orientation(b, c, p) >= 0 && orientation(c, a, p) >= 0;
    };
    size_t cursor = 0;
    while (polygon.size() > 3) {
        const size_t n = polygon.size();
        bool clipped = false;
        for (int pass = 0; pass < 2 && !clipped; ++pass)
            for (size_t step = 0; step < n && !clipped; ++step) {
                const size_t i = (cursor + step) % n;
                const uint32_t p = polygon[(i + n - 1) % n], c = polygon[i], q = polygon[(i + 1) % n];
                const GridPoint a = v[p].at, b = v[c].at, d = v[q].at;
                const int turn = orientation(a, b, d);
                if (pass == 0) {
                    if (turn <= 0) continue;
                    bool empty = true;
                    for (size_t k = 0; k < n && empty; ++k) {
                        const GridPoint w = v[polygon[k]].at;
                        if (w == a || w == b || w == d) continue;
                        empty = !contains(a, b, d, w);
                    }
                    if (!empty) continue;
                } else if (turn != 0) {
                    continue;
                }
                skirt_.triangles.insert(skirt_.triangles.end(), {p, c, q});
                polygon.erase(polygon.begin() + std::ptrdiff_t(i));
                cursor = i == 0 ? 0 : i - 1;
                clipped = true;
            }
        if (!clipped) fail(cell, "its part outside the footprint is not a simple polygon on the lattice");
    }
    if (polygon.size() == 3) {
        if (orientation(v[polygon[0]].at, v[polygon[1]].at, v[polygon[2]].at) < 0) fail(cell, "a polygon turns the wrong way");
        skirt_.triangles.insert(skirt_.triangles.end(), polygon.begin(), polygon.end());
    }
}

void SkirtBuilder::fail(Cell cell, const std::string& why) const {
    throw InputError(what_ + ": cannot cut the raster cell at column " + std::to_string(cell.x) + ", row " + std::to_string(cell.y) +
                     " along the embedded mesh's boundary: " + why);
}

Skirt SkirtBuilder::build(const CellCovers& zone) {
    split_ring();
    // The covers of the finest cells under the moved ring: a cell with no piece of it lies wholly inside
    // or outside (one scanline a row, not a ring's length a cell).
    const CellCovers finest = classify_cells(ring_, 1, columns_, rows_);
    for_each_finest_cell(zone, columns_, rows_, [&](int64_t x, int64_t y) {
        const auto pieces = pieces_.find({x, y});
        if (holed_ && *holed_ == Cell{x, y}) holed_cell({x, y});
        else if (pieces != pieces_.end()) cut_cell({x, y}, pieces->second);
        else if (finest.at(x, y) == CellCover::none) grid_cell({x, y});
        else if (finest.at(x, y) == CellCover::partly && !ring_contains(ring_, {x * kOne + kOne / 2, y * kOne + kOne / 2})) grid_cell({x, y});
    });
    return std::move(skirt_);
}

}  // namespace

Skirt build_skirt(const Footprint& footprint, const CellCovers& zone, int64_t columns, int64_t rows, const std::string& what) {
    return SkirtBuilder(footprint, columns, rows, what).build(zone);
}

}  // namespace strata
