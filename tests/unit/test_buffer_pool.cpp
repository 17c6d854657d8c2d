// The GPU buffer pool (engine/gl/buffer_pool.h): best-fit ranges checked against a unit-by-unit
// reference over long random runs, merging of freed neighbours, refused double frees; pages of real
// storage buffers on llvmpipe, read back after uploads, given up when empty.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include "engine/gl/buffer_pool.h"
#include "engine/gl/context.h"

namespace strata::gl {
namespace {

TEST(RangeAllocator, TakesTheSmallestFreeRangeThatFits) {
    RangeAllocator ranges(100);
    const uint64_t a = *ranges.allocate(10), b = *ranges.allocate(30), c = *ranges.allocate(5), d = *ranges.allocate(20);
    EXPECT_EQ(a, 0u);
    EXPECT_EQ(b, 10u);
    EXPECT_EQ(c, 40u);
    EXPECT_EQ(d, 45u);
    ranges.free(b, 30);  // holes: [10, 40) of 30 and [65, 100) of 35
    EXPECT_EQ(*ranges.allocate(25), 10u) << "the 30-unit hole fits 25 more tightly than the 35-unit tail";
    EXPECT_EQ(*ranges.allocate(32), 65u);
    EXPECT_FALSE(ranges.allocate(6)) << "only 5 + 3 units are free, in two pieces";
    EXPECT_EQ(ranges.used(), 92u);
    EXPECT_EQ(ranges.largest_free(), 5u);
}

TEST(RangeAllocator, FreedNeighboursMergeBackIntoOneRange) {
    RangeAllocator ranges(64);
    std::vector<uint64_t> offsets;
    for (int i = 0; i < 8; ++i) offsets.push_back(*ranges.allocate(8));
    EXPECT_FALSE(ranges.allocate(1));
    for (int i : {1, 3, 5, 7, 0, 2, 6, 4}) ranges.free(offsets[i], 8);  // merging on the left, the right and both
    EXPECT_EQ(ranges.free_ranges(), 1u);
    EXPECT_EQ(ranges.largest_free(), 64u);
    EXPECT_EQ(ranges.used(), 0u);
    EXPECT_EQ(*ranges.allocate(64), 0u);
}

TEST(RangeAllocator, RefusesRangesThatAreFreeOrOutside) {
    RangeAllocator ranges(50);
    const uint64_t a = *ranges.allocate(10);
    *ranges.allocate(10);
    ranges.free(a, 10);
    EXPECT_THROW(ranges.free(a, 10), std::logic_error) << "freed twice";
    EXPECT_THROW(ranges.free(5, 10), std::logic_error) << "overlaps a free range on its left";
    EXPECT_THROW(ranges.free(15, 10), std::logic_error) << "overlaps the free tail";
    EXPECT_THROW(ranges.free(45, 10), std::logic_error) << "past the end";
    EXPECT_THROW(ranges.allocate(0), std::logic_error);
    EXPECT_EQ(ranges.used(), 10u);
}

// Thousands of allocations and frees in random order, against a map of which units are taken: no
// range overlaps another or leaves the capacity, used() counts exactly, and a request fails only
// when no run of free units is that long.
TEST(RangeAllocator, RandomRunsMatchAUnitByUnitReference) {
    constexpr uint64_t kCapacity = 4096;
    RangeAllocator ranges(kCapacity);
    std::vector<bool> taken(kCapacity, false);
    struct Live {
        uint64_t offset, size;
    };
    std::vector<Live> live;
    std::mt19937 random(7);
    auto longest_free_run = [&] {
        uint64_t best = 0, run = 0;
        for (bool t : taken) best = std::max(best, run = t ? 0 : run + 1);
        return best;
    };
    for (int step = 0; step < 20000; ++step) {
        if (live.empty() || random() % 100 < 55) {
            const uint64_t size = 1 + random() % 96;
            const auto offset = ranges.allocate(size);
            if (!offset) {
                ASSERT_LT(longest_free_run(), size) << "step " << step;
                continue;
            }
            ASSERT_LE(*offset + size, kCapacity);
            for (uint64_t u = *offset; u < *offset + size; ++u) {
                ASSERT_FALSE(taken[u]) << "unit " << u << " given twice at step " << step;
                taken[u] = true;
            }
            live.push_back({*offset, size});
        } else {
            const size_t k = random() % live.size();
            ranges.free(live[k].offset, live[k].size);
            for (uint64_t u = live[k].offset; u < live[k].offset + live[k].size; ++u) taken[u] = false;
            live[k] = live.back();
            live.pop_back();
        }
        ASSERT_EQ(ranges.used(), uint64_t(std::count(taken.begin(), taken.end(), true)));
        ASSERT_EQ(ranges.largest_free(), longest_free_run()) << "step " << step;
    }
}

class BufferPoolTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() { context_ = create_headless_context(); }
    static void TearDownTestSuite() { context_.reset(); }
    static inline std::unique_ptr<Context> context_;
};

std::vector<uint32_t> words(uint32_t first, size_t count) {
    std::vector<uint32_t> values(count);
    for (size_t i = 0; i < count; ++i) values[i] = first + uint32_t(i);
    return values;
}

TEST_F(BufferPoolTest, BlocksHoldWhatWasUploadedWhileOthersComeAndGo) {
    BufferPool pool(1024);  // 64 units a page
    EXPECT_EQ(pool.page_units(), 64u);
    BufferPool::Block a = pool.allocate(20), b = pool.allocate(30), c = pool.allocate(10);
    EXPECT_EQ(pool.page_count(), 1u);
    pool.upload(a, 0, words(1000, 80).data(), 80 * 4);
    pool.upload(b, 0, words(2000, 120).data(), 120 * 4);
    pool.upload(c, 2, words(3000, 32).data(), 32 * 4);  // 8 units into the block, at its third
    pool.free(b);
    EXPECT_FALSE(b);
    BufferPool::Block d = pool.allocate(25);  // in b's place
    EXPECT_EQ(d.page, a.page);
    pool.upload(d, 0, words(4000, 100).data(), 100 * 4);
    const Buffer& page = pool.page(a.page);
    EXPECT_EQ(page.download<uint32_t>(80, a.offset * 16), words(1000, 80));
    EXPECT_EQ(page.download<uint32_t>(32, (c.offset + 2) * 16), words(3000, 32));
    EXPECT_EQ(page.download<uint32_t>(100, d.offset * 16), words(4000, 100));
    EXPECT_EQ(pool.used_bytes(), (20 + 10 + 25) * 16u);
    EXPECT_EQ(pool.capacity_bytes(), 1024u);
    EXPECT_THROW(pool.upload(c, 8, words(0, 12).data(), 12 * 4), GlError) << "past the block's end";
}

TEST_F(BufferPoolTest, NewPagesWhenFullAndAPageOfItsOwnForALargeBlock) {
    BufferPool pool(1024);
    BufferPool::Block a = pool.allocate(40), b = pool.allocate(40);
    EXPECT_NE(a.page, b.page) << "two 40-unit blocks do not share a 64-unit page";
    BufferPool::Block large = pool.allocate(200);
    EXPECT_EQ(pool.page_count(), 3u);
    EXPECT_EQ(pool.page(large.page).size(), 200u * 16);
    pool.upload(large, 0, words(7, 800).data(), 800 * 4);
    EXPECT_EQ(pool.page(large.page).download<uint32_t>(800), words(7, 800));
    EXPECT_EQ(pool.capacity_bytes(), 2 * 1024u + 200 * 16);
    // An empty page is given back; its slot is taken by the next page made.
    pool.free(large);
    EXPECT_EQ(pool.capacity_bytes(), 2 * 1024u);
    EXPECT_EQ(pool.page(2).id(), 0u);
    BufferPool::Block c = pool.allocate(60);
    EXPECT_EQ(c.page, 2u);
    pool.free(a), pool.free(b), pool.free(c);
    EXPECT_EQ(pool.capacity_bytes(), 0u);
    EXPECT_EQ(pool.used_bytes(), 0u);
}

// Pages grow with the pool, from 1 MiB up to the page size: a small scene takes little more than it
// holds, a large one takes few pages. A new page size applies to pages made from then on.
TEST_F(BufferPoolTest, PagesGrowAsLargeAsThePoolUpToThePageSize) {
    constexpr uint64_t MiB = uint64_t(1) << 20, unit = BufferPool::kUnitBytes;
    BufferPool pool(8 * MiB);
    std::vector<BufferPool::Block> blocks;
    std::vector<uint64_t> sizes;
    for (int k = 0; k < 6; ++k) {
        // Each block fills a page of its own: as large as the pool is, at least 1 MiB, at most 8 MiB.
        const uint64_t grown = std::min<uint64_t>(std::max<uint64_t>(MiB, pool.capacity_bytes()), 8 * MiB);
        blocks.push_back(pool.allocate(grown / unit));
        sizes.push_back(pool.page(blocks.back().page).size());
    }
    EXPECT_EQ(sizes, (std::vector<uint64_t>{MiB, MiB, 2 * MiB, 4 * MiB, 8 * MiB, 8 * MiB}));
    pool.set_page_bytes(2 * MiB);
    const BufferPool::Block small = pool.allocate(1);
    EXPECT_EQ(pool.page(small.page).size(), 2 * MiB);
}

// Pages that evictions left partly empty go back: once the free room passes two pages, the page with
// the most retires (nothing more is placed there) until its owners have placed its blocks elsewhere.
TEST_F(BufferPoolTest, ThePageWithTheMostFreeRoomRetiresOnceThePagesHoldMoreThanTwoPagesOfIt) {
    BufferPool pool(1024);  // 64 units a page
    std::vector<BufferPool::Block> blocks;
    for (int k = 0; k < 10; ++k) blocks.push_back(pool.allocate(32));  // two a page, five pages
    ASSERT_EQ(pool.page_count(), 5u);
    pool.free(blocks[8]);  // page 4
    pool.free(blocks[1]), pool.free(blocks[3]), pool.free(blocks[5]);  // pages 0, 1, 2: free room 128 units
    EXPECT_EQ(pool.retiring_page(), BufferPool::kNoPage) << "two pages of free room are allowed";
    pool.free(blocks[7]);  // page 3: 160 units free, 32 on each page
    const uint32_t retiring = pool.retiring_page();
    ASSERT_NE(retiring, BufferPool::kNoPage);
    const BufferPool::Block placed = pool.allocate(32);
    EXPECT_NE(placed.page, retiring) << "nothing is placed on a retiring page";
    // Its owner places its last block again elsewhere: the page goes back, and no other retires.
    BufferPool::Block& last = blocks[2 * retiring + 1] ? blocks[2 * retiring + 1] : blocks[2 * retiring];
    ASSERT_EQ(last.page, retiring);
    pool.upload(last, 0, words(5, 128).data(), 128 * 4);
    const std::vector<uint32_t> kept = pool.page(retiring).download<uint32_t>(128, last.offset * 16);
    pool.free(last);
    last = pool.allocate(32);
    pool.upload(last, 0, kept.data(), 128 * 4);
    EXPECT_EQ(pool.page(retiring).id(), 0u);
    EXPECT_EQ(pool.retiring_page(), BufferPool::kNoPage);
    EXPECT_EQ(pool.capacity_bytes(), 4 * 1024u);
    EXPECT_EQ(pool.used_bytes(), 6 * 32 * 16u);
    EXPECT_EQ(pool.page(last.page).download<uint32_t>(128, last.offset * 16), words(5, 128));
}

TEST_F(BufferPoolTest, ABlockNoBindingCanHoldIsAnError) {
    GLint64 max_block = 0;
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_block);
    BufferPool pool(uint64_t(1) << 40);
    EXPECT_EQ(pool.page_units(), uint64_t(max_block) / 16) << "pages no larger than one binding";
    try {
        pool.allocate(uint64_t(max_block) / 16 + 1);
        FAIL() << "a block larger than a binding was placed";
    } catch (const GlError& e) {
        EXPECT_NE(std::string(e.what()).find("storage buffer binding"), std::string::npos) << e.what();
    }
    EXPECT_EQ(pool.capacity_bytes(), 0u);
}

}  // namespace
}  // namespace strata::gl
