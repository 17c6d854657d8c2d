// The ring seam (preprocess/ring_seam.h): the zone's border in finest steps, one counter-clockwise loop
// per boundary component (a hole too), steps along the raster's border unseamed; and for any levels the
// grid beside the border is drawn at (cube by cube, fine or coarse), the seam closes every grid edge on
// the border against the skirt's finest samples, each edge matched by exactly one reverse edge.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <tuple>

#include "preprocess/ring_seam.h"

namespace strata {
namespace {

// A zone of level-m cells of `size` finest steps, `cells` (x, y) in a raster of `raster` samples a side.
CellCovers zone_of(int64_t size, const std::vector<std::pair<int64_t, int64_t>>& cells, int64_t raster) {
    CellCovers zone;
    zone.size = size;
    zone.first_x = zone.first_y = 0;
    zone.width = zone.height = (raster - 1 + size - 1) / size;
    zone.cover.assign(size_t(zone.width * zone.height), CellCover::none);
    for (const auto& [x, y] : cells) zone.cover[size_t(y * zone.width + x)] = CellCover::partly;
    return zone;
}

int64_t twice_area(const std::vector<BorderStep>& loop) {
    int64_t sum = 0;
    for (size_t i = 0; i < loop.size(); ++i) {
        const BorderStep &a = loop[i], &b = loop[(i + 1) % loop.size()];
        sum += a.column * b.row - b.column * a.row;
    }
    return sum;
}

TEST(RingSeam, TheZonesBorderIsOneCounterClockwiseLoopPerComponent) {
    // Two cells of 4: a 8 × 4 rectangle, its 24 steps all seamed, each with the cell beyond it.
    auto loops = zone_border(zone_of(4, {{1, 1}, {2, 1}}, 33), 33, 33);
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_EQ(loops[0].size(), 24u);
    EXPECT_EQ(twice_area(loops[0]), 2 * 32);
    for (const BorderStep& s : loops[0]) {
        EXPECT_TRUE(s.seamed());
        const bool outside = s.outside_column < 4 || s.outside_column >= 12 || s.outside_row < 4 || s.outside_row >= 8;
        EXPECT_TRUE(outside) << s.outside_column << ", " << s.outside_row;
    }
    // A ring of eight cells around an uncovered one: the outer loop and the hole's, which runs clockwise.
    loops = zone_border(zone_of(2, {{1, 1}, {2, 1}, {3, 1}, {1, 2}, {3, 2}, {1, 3}, {2, 3}, {3, 3}}, 33), 33, 33);
    ASSERT_EQ(loops.size(), 2u);
    EXPECT_EQ(twice_area(loops[0]) + twice_area(loops[1]), 2 * 8 * 4);
    EXPECT_EQ(std::min(twice_area(loops[0]), twice_area(loops[1])), -2 * 4);
    // Along the raster's own border: no grid beyond, no seam.
    loops = zone_border(zone_of(4, {{0, 0}}, 33), 33, 33);
    ASSERT_EQ(loops.size(), 1u);
    size_t unseamed = 0;
    for (const BorderStep& s : loops[0]) unseamed += !s.seamed();
    EXPECT_EQ(unseamed, 8u);
}

using Key = std::tuple<bool, int64_t, int64_t>;  // grid?, column, row: a vertex by where it is drawn

Key key(const SeamVertex& v, std::span<const BorderStep> loop) {
    return v.grid ? Key{true, v.column, v.row} : Key{false, loop[v.step].column, loop[v.step].row};
}

// For levels chosen per block of 8 × 8 finest cells (as cubes are: one level each, any of the three
// finest), the seam, the skirt's border edges and the grid's border edges at those levels close up.
void expect_closed(const std::vector<BorderStep>& loop, uint32_t finest, int64_t raster, std::mt19937& random) {
    std::map<std::pair<int64_t, int64_t>, uint32_t> block_level;
    std::vector<uint32_t> levels;
    for (const BorderStep& s : loop) {
        const auto block = std::make_pair(s.outside_column / 8, s.outside_row / 8);
        auto it = block_level.find(block);
        if (it == block_level.end()) it = block_level.emplace(block, finest - uint32_t(random() % 4)).first;
        levels.push_back(it->second);
    }
    std::map<std::pair<Key, Key>, int> edges;
    const auto seam = ring_seam(loop, levels, finest, raster, raster);
    for (const auto& t : seam)
        for (int k = 0; k < 3; ++k) ++edges[{key(t[k], loop), key(t[(k + 1) % 3], loop)}];
    const size_t n = loop.size();
    for (size_t i = 0; i < n; ++i) {
        const BorderStep &a = loop[i], &b = loop[(i + 1) % n];
        ++edges[{Key{false, a.column, a.row}, Key{false, b.column, b.row}}];  // the skirt's side
        // The grid's side: the level's edge holding the step, once, backwards (the grid lies to the right).
        const int64_t size = int64_t(1) << (finest - levels[i]);
        const bool along_row = a.row == b.row;
        const int64_t t = std::min(along_row ? a.column : a.row, along_row ? b.column : b.row);
        if (t % size != 0) continue;
        const int64_t lo = t, hi = std::min(t + size, raster - 1);
        const Key low = along_row ? Key{true, lo, a.row} : Key{true, a.column, lo}, high = along_row ? Key{true, hi, a.row} : Key{true, a.column, hi};
        const bool forward = (along_row ? b.column - a.column : b.row - a.row) > 0;
        ++edges[forward ? std::pair{high, low} : std::pair{low, high}];
    }
    for (const auto& [edge, count] : edges) {
        const auto back = edges.find({edge.second, edge.first});
        ASSERT_NE(back, edges.end()) << "an edge without its reverse, at (" << std::get<1>(edge.first) << ", " << std::get<2>(edge.first) << ") → ("
                                     << std::get<1>(edge.second) << ", " << std::get<2>(edge.second) << ")";
        EXPECT_EQ(back->second, count);
    }
}

TEST(RingSeam, ClosesTheGridEdgesAgainstTheSkirtAtAnyLevelsAlongTheBorder) {
    std::mt19937 random(7);
    const uint32_t finest = 6;  // cells of the zone's level m = 3: 8 finest steps
    for (int trial = 0; trial < 50; ++trial) {
        std::vector<std::pair<int64_t, int64_t>> cells;
        for (int64_t y = 1; y < 7; ++y)
            for (int64_t x = 1; x < 7; ++x)
                if (random() % 3 != 0) cells.emplace_back(x, y);
        if (cells.empty()) continue;
        for (const auto& loop : zone_border(zone_of(8, cells, 65), 65, 65)) expect_closed(loop, finest, 65, random);
        if (HasFailure()) break;
    }
}

}  // namespace
}  // namespace strata
