// The border table (DESIGN.md §2, "Blocks"): which block listed a point, whether several did, and the
// normal sums of all listings, found by position bits; and the IndexMap lookup it stands on.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "preprocess/border_table.h"
#include "preprocess/index_map.h"

namespace strata::build {
namespace {

BorderEntry entry(float x, float y, float z, CubeKey block, CubeKey cube, float normal_x) {
    const float p[3] = {x, y, z};
    return BorderEntry{position_bits(p), block, cube, {normal_x, 0, 0}};
}

TEST(BorderTable, FindsEveryListedPointAndNothingElse) {
    // Points on a 20×20×20 lattice; block 1 lists them all, block 2 (a later cube) every third one.
    std::vector<BorderEntry> entries;
    for (int i = 0; i < 8000; ++i) {
        const float x = float(i % 20) * 0.25f, y = float(i / 20 % 20) * 0.25f, z = float(i / 400) * 0.25f;
        entries.push_back(entry(x, y, z, 1, 10, 1.0f));
        if (i % 3 == 0) entries.push_back(entry(x, y, z, 2, 20, 0.5f));
    }
    const BorderTable table(entries);
    ASSERT_EQ(table.size(), 8000u);
    for (int i = 0; i < 8000; ++i) {
        const float p[3] = {float(i % 20) * 0.25f, float(i / 20 % 20) * 0.25f, float(i / 400) * 0.25f};
        const BorderTable::Point* point = table.find(position_bits(p));
        ASSERT_NE(point, nullptr) << "point " << i;
        EXPECT_EQ(point->first_block, 1u);
        EXPECT_EQ(point->several_blocks, i % 3 == 0);
        EXPECT_FLOAT_EQ(point->normal_sum[0], i % 3 == 0 ? 1.5f : 1.0f);
        EXPECT_EQ(point->locked_for(1), i % 3 == 0);
        EXPECT_TRUE(point->locked_for(2));
        // Half a step off the lattice: never listed.
        const float off[3] = {p[0] + 0.125f, p[1], p[2]};
        EXPECT_EQ(table.find(position_bits(off)), nullptr) << "point " << i;
    }
    // −0 is +0: the same point.
    const float negative_zero[3] = {-0.0f, -0.0f, -0.0f};
    ASSERT_NE(table.find(position_bits(negative_zero)), nullptr);
    EXPECT_EQ(BorderTable().find(position_bits(negative_zero)), nullptr);
}

TEST(IndexMap, LookupOnlySetModeFindsWhatWasInserted) {
    const std::vector<uint32_t> values = {7, 70, 700, 7000, 70000};
    IndexMap set(values.size());
    auto hash = [](uint32_t v) { return uint64_t(v % 4); };  // collisions on purpose
    for (uint32_t i = 0; i < values.size(); ++i)
        set.find_or_insert(hash(values[i]), i, [&](uint32_t stored) { return values[stored] == values[i]; });
    for (uint32_t i = 0; i < values.size(); ++i)
        EXPECT_EQ(set.find(hash(values[i]), [&](uint32_t stored) { return values[stored] == values[i]; }), i);
    EXPECT_EQ(set.find(hash(71), [&](uint32_t stored) { return values[stored] == 71; }), IndexMap::kMissing);
}

}  // namespace
}  // namespace strata::build
