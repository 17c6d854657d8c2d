// The residency cache (engine/stream/stream_cache.h) with a source of its own: an octree of items of
// known sizes loaded on the cache's real threads, a gate that holds loads in flight, and items that
// fail. Tests wait for the cache's state (wait_for_requests, the gate's count), never for a time.
#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>
#include <random>
#include <set>

#include "engine/stream/stream_cache.h"

namespace strata {
namespace {

// An octree `depth` levels deep, items numbered breadth first; item i's value is its index, and its
// bytes are 1000 + 10·(i mod 7) (the bound says 1100), half of them on the GPU (the bound says 550).
class TreeSource : public StreamSource {
public:
    explicit TreeSource(int depth) {
        uint32_t count = 0, level_size = 1;
        for (int l = 0; l < depth; ++l, level_size *= 8) {
            for (uint32_t i = 0; i < level_size; ++i) parents_.push_back(l == 0 ? kNoItem : first_of_level_.back() + i / 8);
            first_of_level_.push_back(count);
            count += level_size;
        }
    }
    uint32_t item_count() const override { return uint32_t(parents_.size()); }
    uint32_t parent(uint32_t item) const override { return parents_[item]; }
    uint64_t item_bytes(uint32_t) const override { return 1100; }
    uint64_t item_gpu_bytes(uint32_t) const override { return 550; }
    // Kept resident: `pinned` items under a budget of at least `pin_budget`, none under a smaller one.
    std::vector<uint32_t> pinned_items(uint64_t budget) const override { return budget >= pin_budget ? pinned : std::vector<uint32_t>{}; }
    std::vector<uint32_t> pinned;
    uint64_t pin_budget = 0;
    static uint64_t actual_bytes(uint32_t item) { return 1000 + 10 * (item % 7); }
    uint32_t first_of_level(int level) const { return first_of_level_[size_t(level)]; }

    Loaded load(uint32_t item, const std::shared_ptr<const void>& parent) override {
        {
            std::unique_lock lock(mutex_);
            ++started_;
            changed_.notify_all();
            changed_.wait(lock, [&] { return open_; });
            // Parents come first: the cache hands each load its parent's value.
            if ((parents_[item] == kNoItem) != (parent == nullptr) ||
                (parent && *static_cast<const uint32_t*>(parent.get()) != parents_[item]))
                wrong_parent_ = true;
            order_.push_back(item);
        }
        if (failing_.count(item)) throw std::runtime_error("tree: item " + std::to_string(item) + " is unreadable");
        const uint64_t bytes = over_bound_.count(item) ? 2000 : actual_bytes(item);
        return {std::make_shared<const uint32_t>(item), bytes, std::min<uint64_t>(bytes / 2, 550)};
    }

    // The gate: closed, loads wait inside load() once started.
    void set_open(bool open) {
        {
            const std::lock_guard lock(mutex_);
            open_ = open;
        }
        changed_.notify_all();
    }
    void wait_until_started(size_t count) {
        std::unique_lock lock(mutex_);
        changed_.wait(lock, [&] { return started_ >= count; });
    }
    std::vector<uint32_t> order() const {
        const std::lock_guard lock(mutex_);
        return order_;
    }
    bool wrong_parent() const { return wrong_parent_; }
    std::set<uint32_t> failing_, over_bound_;

private:
    std::vector<uint32_t> parents_, first_of_level_;
    mutable std::mutex mutex_;
    std::condition_variable changed_;
    bool open_ = true, wrong_parent_ = false;
    size_t started_ = 0;
    std::vector<uint32_t> order_;
};

// A budget of `items` bytes for the items, beside the table the cache keeps of them (held in the
// budget too).
uint64_t beside_the_table(uint64_t items, const TreeSource& tree) { return items + StreamCache::table_bytes(tree.item_count()); }

// Every resident item's ancestors are resident, and the resident bytes are exactly the loaded items'.
void expect_consistent(const StreamCache& cache, StreamCache::SourceId id, const TreeSource& tree) {
    uint64_t bytes = 0;
    for (uint32_t i = 0; i < tree.item_count(); ++i) {
        if (!cache.resident(id, i)) continue;
        bytes += TreeSource::actual_bytes(i);
        if (tree.parent(i) != StreamSource::kNoItem) {
            EXPECT_TRUE(cache.resident(id, tree.parent(i))) << "item " << i;
        }
    }
    const StreamCache::Stats s = cache.stats();
    EXPECT_EQ(s.resident_bytes, bytes);
    EXPECT_EQ(s.held_bytes, StreamCache::table_bytes(tree.item_count()));
    EXPECT_LE(s.resident_bytes + s.reserved_bytes + s.held_bytes, s.budget);
    EXPECT_LE(s.peak_bytes, s.budget);
}

// What open models hold beside the items (their per-item tables) counts in the budget: holding it
// evicts the least recently used items to make room, a hold that cannot fit is refused naming the
// figures, and the bytes come back when the handle goes.
TEST(StreamCache, HeldBytesCountInTheBudgetEvictToMakeRoomAndComeBack) {
    auto tree = std::make_shared<TreeSource>(3);
    StreamCache cache(beside_the_table(6 * 1100, *tree), 1);
    const auto id = cache.add(tree);
    const uint32_t child = tree->first_of_level(2);
    for (uint32_t k = 0; k < 4; ++k) {  // the root, its first child, and four leaves: 0 the oldest
        cache.request(id, child + k, 1.0);
        cache.wait_for_requests();
    }
    const uint64_t table = StreamCache::table_bytes(tree->item_count());
    EXPECT_EQ(cache.stats().held_bytes, table);
    {
        const StreamCache::Held held = cache.hold(2000, 300, "two leaves' worth");
        const StreamCache::Stats s = cache.stats();
        EXPECT_EQ(s.held_bytes, table + 2000);
        EXPECT_EQ(s.gpu_held_bytes, 300u);
        EXPECT_FALSE(cache.resident(id, child + 0)) << "the least recently used leaves made room";
        EXPECT_FALSE(cache.resident(id, child + 1));
        EXPECT_TRUE(cache.resident(id, child + 2));
        EXPECT_LE(s.resident_bytes + s.reserved_bytes + s.held_bytes, s.budget);
        EXPECT_LE(s.peak_bytes, s.budget);
        try {
            (void)cache.hold(10 * 1100, 0, "a model's tables");
            FAIL() << "a hold beyond the budget was taken";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("a model's tables take"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("streaming budget"), std::string::npos) << e.what();
        }
        EXPECT_EQ(cache.stats().held_bytes, table + 2000) << "a refused hold holds nothing";
        EXPECT_THROW(cache.set_budget(table + 1999), std::invalid_argument) << "below what is held";
        EXPECT_THROW(cache.set_gpu_budget(299), std::invalid_argument) << "below what is held on the GPU";
    }
    EXPECT_EQ(cache.stats().held_bytes, table) << "the bytes came back with the handle";
    EXPECT_EQ(cache.stats().gpu_held_bytes, 0u);
    cache.remove(id);
    EXPECT_EQ(cache.stats().held_bytes, 0u) << "the source's table went with it";
}

TEST(StreamCache, AnItemLoadsAfterItsAncestorsEachGivenItsParent) {
    auto tree = std::make_shared<TreeSource>(4);
    StreamCache cache(1 << 20, 3);
    const auto id = cache.add(tree);
    const uint32_t leaf = tree->first_of_level(3) + 77;
    cache.request(id, leaf, 1.0);
    cache.wait_for_requests();
    for (uint32_t i = leaf; i != StreamSource::kNoItem; i = tree->parent(i)) EXPECT_TRUE(cache.resident(id, i)) << i;
    EXPECT_EQ(*static_cast<const uint32_t*>(cache.value(id, leaf).get()), leaf);
    EXPECT_EQ(tree->order().size(), 4u);  // the leaf and its three ancestors, nothing else
    EXPECT_FALSE(tree->wrong_parent());
    EXPECT_EQ(cache.stats().loaded, 4u);
    expect_consistent(cache, id, *tree);
}

TEST(StreamCache, TheBudgetIsAHardCapOverManyFramesOfRandomViews) {
    auto tree = std::make_shared<TreeSource>(4);  // 585 items, about 600 kB
    const uint64_t budget = 60 * 1100;            // a tenth of them
    StreamCache cache(budget, 2);
    const auto id = cache.add(tree);
    std::mt19937 rng(3);
    for (int frame = 0; frame < 300; ++frame) {
        // A "view": a few leaves near one another, the ones drawn last frame touched.
        const uint32_t around = tree->first_of_level(3) + rng() % 512;
        for (uint32_t k = 0; k < 6; ++k) {
            const uint32_t item = tree->first_of_level(3) + (around + k * 3) % 512;
            if (cache.resident(id, item)) cache.touch(id, item);
            else cache.request(id, item, double(rng() % 100));
        }
        cache.update();
        expect_consistent(cache, id, *tree);
        if (frame % 50 == 49) {  // a capture: everything of one view, waited for
            for (uint32_t k = 0; k < 6; ++k) cache.request(id, tree->first_of_level(3) + (around + k * 3) % 512, 1.0);
            cache.wait_for_requests();
            expect_consistent(cache, id, *tree);
        }
    }
    const StreamCache::Stats s = cache.stats();
    EXPECT_GT(s.evicted, 100u) << "the views needed more than the budget over time";
    EXPECT_GT(s.peak_bytes, budget * 9 / 10) << "the cache used its room";
    EXPECT_FALSE(tree->wrong_parent());
}

TEST(StreamCache, TheLeastRecentlyUsedLeavesGoFirstAndNothingThisFrameUses) {
    auto tree = std::make_shared<TreeSource>(3);
    StreamCache cache(beside_the_table(6 * 1100, *tree), 1);  // the root, one level-1 item and four of its children
    const auto id = cache.add(tree);
    const uint32_t mid = tree->first_of_level(1), child = tree->first_of_level(2);
    for (uint32_t k = 0; k < 4; ++k) {  // children 0..3, one per frame: 0 is the oldest
        cache.request(id, child + k, 1.0);
        cache.wait_for_requests();
    }
    cache.touch(id, child + 0);  // used again this frame: stays
    cache.request(id, child + 4, 1.0);
    cache.wait_for_requests();
    EXPECT_TRUE(cache.resident(id, child + 0));
    EXPECT_FALSE(cache.resident(id, child + 1)) << "the least recently used leaf goes";
    EXPECT_TRUE(cache.resident(id, child + 2));
    EXPECT_TRUE(cache.resident(id, child + 4));
    EXPECT_TRUE(cache.resident(id, mid)) << "a parent with resident children never goes";
    EXPECT_EQ(cache.stats().evicted, 1u);
    expect_consistent(cache, id, *tree);
}

TEST(StreamCache, HigherPriorityLoadsFirstWhenOnlyOneFits) {
    auto tree = std::make_shared<TreeSource>(2);
    StreamCache cache(beside_the_table(2 * 1100, *tree), 1);  // the root and one child
    const auto id = cache.add(tree);
    cache.request(id, 0, 1.0);
    cache.wait_for_requests();
    cache.request(id, 3, 1.0);
    cache.request(id, 5, 9.0);
    cache.touch(id, 0);
    cache.update();
    EXPECT_EQ(cache.stats().shortfall, 1100u) << "the second did not fit";
    cache.request(id, 5, 9.0);
    cache.wait_for_requests();
    EXPECT_TRUE(cache.resident(id, 5));
    EXPECT_FALSE(cache.resident(id, 3));
}

// Prefetches: ancestors first, after the frame's requests, only into free room (never evicting), and
// neither counted as requests nor waited for.
TEST(StreamCache, PrefetchesFillFreeRoomAfterTheRequestsAndNeverEvict) {
    auto tree = std::make_shared<TreeSource>(3);
    StreamCache cache(beside_the_table(4 * 1100, *tree), 1);  // the root, its first child and two leaves under it
    const auto id = cache.add(tree);
    cache.request(id, 0, 1.0);
    cache.wait_for_requests();
    const uint32_t mid = tree->first_of_level(1), leaf = tree->first_of_level(2);  // leaf's parent is mid
    // Two frames of the same prefetch: its parent loads first, then it.
    for (int frame = 0; frame < 2; ++frame) {
        cache.prefetch(id, leaf, 1.0);
        EXPECT_FALSE(cache.has_requests()) << "a prefetch is not a request";
        cache.update();
        EXPECT_EQ(cache.stats().prefetch_waiting, frame == 0 ? 1u : 0u) << "frame " << frame;
        cache.wait_for_a_load();
        cache.update();
    }
    EXPECT_TRUE(cache.resident(id, mid));
    EXPECT_TRUE(cache.resident(id, leaf));
    // One item of room left: a request takes it before a prefetch of higher priority.
    cache.request(id, leaf + 1, 1.0);
    cache.prefetch(id, leaf + 2, 100.0);
    cache.update();
    EXPECT_EQ(cache.stats().prefetch_waiting, 1u);
    cache.request(id, leaf + 1, 1.0);
    cache.wait_for_requests();
    EXPECT_TRUE(cache.resident(id, leaf + 1));
    // The budget is full: a prefetch evicts nothing, though least recently used leaves could go, and
    // is not waited for (a wait for it would find no room and throw).
    cache.prefetch(id, leaf + 3, 1.0);
    EXPECT_NO_THROW(cache.wait_for_requests());
    for (int frame = 0; frame < 3; ++frame) {
        cache.prefetch(id, leaf + 3, 1.0);
        cache.update();
        cache.wait_for_a_load();
    }
    cache.update();
    EXPECT_FALSE(cache.resident(id, leaf + 3));
    EXPECT_EQ(cache.stats().evicted, 0u);
    EXPECT_EQ(cache.stats().prefetch_waiting, 0u) << "the last update had no prefetch";
    expect_consistent(cache, id, *tree);
}

// A GPU budget of its own: the GPU bytes of resident items and loads in flight stay within it over
// many frames of random views while the total budget has room to spare, least recently used leaves
// making way; a view whose GPU bytes do not fit is an error that says so.
TEST(StreamCache, AGpuBudgetCapsTheGpuShareOnItsOwn) {
    auto tree = std::make_shared<TreeSource>(4);
    StreamCache cache(1000 * 1100, 2);  // everything fits the total
    cache.set_gpu_budget(40 * 550);     // 40 items' GPU bounds
    const auto id = cache.add(tree);
    std::mt19937 rng(5);
    for (int frame = 0; frame < 200; ++frame) {
        const uint32_t around = tree->first_of_level(3) + rng() % 512;
        for (uint32_t k = 0; k < 6; ++k) cache.request(id, tree->first_of_level(3) + (around + k * 5) % 512, 1.0);
        cache.update();
        cache.wait_for_a_load();
        const StreamCache::Stats s = cache.stats();
        ASSERT_LE(s.gpu_resident_bytes, s.gpu_budget) << "frame " << frame;
        uint64_t gpu = 0;
        for (uint32_t i = 0; i < tree->item_count(); ++i)
            if (cache.resident(id, i)) gpu += TreeSource::actual_bytes(i) / 2;
        ASSERT_EQ(s.gpu_resident_bytes, gpu) << "exact";
        expect_consistent(cache, id, *tree);
    }
    EXPECT_GT(cache.stats().evicted, 50u) << "the GPU budget, not the total, made room";
    for (uint32_t k = 0; k < 64; ++k) cache.request(id, tree->first_of_level(3) + k * 8, 1.0);  // 64 leaves, 64 parents
    try {
        cache.wait_for_requests();
        FAIL() << "a view over the GPU budget was loaded";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("on the GPU"), std::string::npos) << e.what();
    }
}

TEST(StreamCache, LoadsInFlightCountAgainstTheBudget) {
    auto tree = std::make_shared<TreeSource>(2);
    StreamCache cache(beside_the_table(4 * 1100, *tree), 2);
    const auto id = cache.add(tree);
    cache.request(id, 0, 1.0);
    cache.wait_for_requests();
    tree->set_open(false);
    for (uint32_t c = 1; c <= 8; ++c) cache.request(id, c, 1.0);
    cache.update();
    const StreamCache::Stats s = cache.stats();
    EXPECT_EQ(s.in_flight, 3u) << "three children's bounds fit beside the root";
    EXPECT_EQ(s.reserved_bytes, 3 * 1100u);
    EXPECT_EQ(s.shortfall, 5 * 1100u);
    tree->wait_until_started(3);  // the root and two loader threads' worth, the third queued
    tree->set_open(true);
    for (uint32_t c = 1; c <= 3; ++c) cache.request(id, c, 1.0);
    cache.wait_for_requests();
    EXPECT_EQ(cache.stats().reserved_bytes, 0u);
    expect_consistent(cache, id, *tree);
}

TEST(StreamCache, AFailedLoadIsReportedNamingItAndNotRetriedUntilForgotten) {
    auto tree = std::make_shared<TreeSource>(3);
    tree->failing_ = {tree->first_of_level(1) + 2};
    StreamCache cache(1 << 20, 2);
    const auto id = cache.add(tree);
    const uint32_t below = tree->first_of_level(2) + 2 * 8 + 5;  // a child of the failing item
    cache.request(id, below, 1.0);
    try {
        cache.wait_for_requests();
        FAIL() << "a failing load was waited for";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("item 3 is unreadable"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(cache.failure(id, 3).has_value());
    EXPECT_FALSE(cache.resident(id, below));
    const uint64_t loads = tree->order().size();
    cache.request(id, 3, 1.0);
    cache.update();
    EXPECT_EQ(cache.stats().in_flight, 0u) << "not retried";
    tree->failing_.clear();
    cache.forget_failure(id, 3);
    cache.request(id, below, 1.0);
    cache.wait_for_requests();
    EXPECT_TRUE(cache.resident(id, below));
    EXPECT_EQ(tree->order().size(), loads + 2);
    EXPECT_EQ(cache.stats().failed, 1u);
}

TEST(StreamCache, WaitingNamesTheShortfallWhenAViewDoesNotFit) {
    auto tree = std::make_shared<TreeSource>(2);
    StreamCache cache(beside_the_table(4 * 1100, *tree), 2);
    const auto id = cache.add(tree);
    for (uint32_t c = 1; c <= 8; ++c) cache.request(id, c, 1.0);
    try {
        cache.wait_for_requests();
        FAIL() << "nine items fitted in the room of four";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("budget"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("short"), std::string::npos) << e.what();
    }
    expect_consistent(cache, id, *tree);
}

TEST(StreamCache, AValueLargerThanItsBoundIsAFailureAndNotCounted) {
    auto tree = std::make_shared<TreeSource>(2);
    tree->over_bound_ = {4};
    StreamCache cache(1 << 20, 1);
    const auto id = cache.add(tree);
    cache.request(id, 4, 1.0);
    EXPECT_THROW(cache.wait_for_requests(), std::runtime_error);
    EXPECT_NE(cache.failure(id, 4)->find("more than its bound"), std::string::npos);
    EXPECT_EQ(cache.stats().resident_bytes, TreeSource::actual_bytes(0));
}

TEST(StreamCache, RemovingASourceDropsItsItemsAndDiscardsItsRunningLoads) {
    auto tree = std::make_shared<TreeSource>(2), other = std::make_shared<TreeSource>(2);
    StreamCache cache(1 << 20, 1);
    const auto id = cache.add(tree), kept = cache.add(other);
    cache.request(id, 0, 1.0);
    cache.request(kept, 0, 1.0);
    cache.wait_for_requests();
    tree->set_open(false);
    for (uint32_t c = 1; c <= 4; ++c) cache.request(id, c, 1.0);
    cache.update();
    tree->wait_until_started(2);  // the root, then one child held in load(); three queued
    cache.remove(id);
    tree->set_open(true);
    cache.request(kept, 1, 1.0);
    cache.wait_for_requests();
    const StreamCache::Stats s = cache.stats();
    EXPECT_EQ(s.resident_bytes, TreeSource::actual_bytes(0) + TreeSource::actual_bytes(1));
    EXPECT_EQ(s.reserved_bytes, 0u);
    EXPECT_EQ(s.in_flight, 0u);
}

// Pinned items load first and stay; a budget too small for the source's pins releases them, and they
// are evicted as room is needed like any other item.
TEST(StreamCache, PinnedItemsLoadFirstAndStayUntilTheBudgetNoLongerPinsThem) {
    auto tree = std::make_shared<TreeSource>(3);
    tree->pinned = {0, 1};
    tree->pin_budget = beside_the_table(4 * 1100, *tree);
    StreamCache cache(beside_the_table(4 * 1100, *tree), 1);
    const auto id = cache.add(tree);
    for (int frame = 0; frame < 8; ++frame) {  // each frame a new leaf under item 2, none touched again
        cache.request(id, tree->first_of_level(2) + 8 + uint32_t(frame), 1.0);
        cache.wait_for_requests();
        EXPECT_TRUE(cache.resident(id, 0));
        EXPECT_TRUE(cache.resident(id, 1));
    }
    EXPECT_GT(cache.stats().evicted, 4u);
    // Three items' room: the pins go, and a leaf under item 2 takes item 1's place (least recently used).
    cache.set_budget(beside_the_table(3 * 1100, *tree));
    cache.request(id, tree->first_of_level(2) + 16, 1.0);
    cache.wait_for_requests();
    EXPECT_FALSE(cache.resident(id, 1)) << "item 1 was still pinned under a budget that pins nothing";
    EXPECT_LE(cache.stats().resident_bytes, 3u * 1100);
    EXPECT_THROW(StreamCache(0, 1), std::invalid_argument);
}

}  // namespace
}  // namespace strata
