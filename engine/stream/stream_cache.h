// The residency cache (DESIGN.md §7): one budget for a whole scene, loader threads, and what is
// resident of each streamed source. It knows no file format: a source (an HLOD model) names its items
// (cubes) by index, gives each a parent and a byte bound known before loading, and loads them.
//
// The rules it keeps:
// - An item is resident only with its parent (and so with all its ancestors): a load starts only once
//   the parent is resident, and only items without resident children are evicted.
// - The budget is a hard cap: the bytes of resident items, those reserved for loads in flight and
//   those held beside the items (hold(): what open models keep per cube) never exceed it. A load
//   reserves its item's bound when it starts; the item's actual bytes, which may be fewer, count once
//   it is resident. resident_bytes is exact.
// - Residency changes only in update(), on the caller's (the render) thread: between two updates
//   what a frame sees stays put. Loads run on the loader threads.
// - Priority: each frame's requests start highest first; to make room, update() evicts the least
//   recently used items that this frame neither touched nor requested.
// - Prefetches (what coming frames will want) start after the requests, only into room the budget has
//   free: they never evict, are never waited for, and do not count as requests.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <queue>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

namespace strata {

class StreamSource {
public:
    static constexpr uint32_t kNoItem = ~0u;
    struct Loaded {
        std::shared_ptr<const void> value;
        uint64_t bytes = 0;      // what the value holds, in CPU and GPU memory together; at most item_bytes()
        uint64_t gpu_bytes = 0;  // of those, what it will hold on the GPU; at most item_gpu_bytes()
    };
    virtual ~StreamSource() = default;
    virtual uint32_t item_count() const = 0;
    virtual uint32_t parent(uint32_t item) const = 0;  // kNoItem for a root
    // An upper bound on what the item takes once loaded, known before loading.
    virtual uint64_t item_bytes(uint32_t item) const = 0;
    // Of that bound, what the item takes on the GPU (what a separate GPU budget counts).
    virtual uint64_t item_gpu_bytes(uint32_t) const { return 0; }
    // The items to keep resident under a budget (a model's coarse levels): never evicted, loaded first
    // and counted in the budget. Asked when the source is added and again whenever the budget changes.
    virtual std::vector<uint32_t> pinned_items(uint64_t /*budget*/) const { return {}; }
    // Runs on a loader thread, given the parent's value (null for a root). Throws std::exception on
    // failure, with a message that names the source and the item.
    virtual Loaded load(uint32_t item, const std::shared_ptr<const void>& parent) = 0;
    // Called on the cache's caller's thread once what is resident of the source has changed, before
    // any new load starts, with the items that came in or left (in no order, maybe twice) and the
    // source's version after them: whatever holds the source's values (a model not drawn this frame)
    // lets go of the evicted ones now, so that they count against the budget only while the cache
    // holds them. It may read the cache (value(), version()), never change it, and must not throw:
    // the loads it comes before are not queued yet.
    virtual void residency_changed(const std::vector<uint32_t>& /*items*/, uint64_t /*version*/) {}
};

class StreamCache {
public:
    using SourceId = uint32_t;
    struct Stats {
        uint64_t budget = 0;
        uint64_t resident_bytes = 0;  // exact: the loaded values' own counts
        uint64_t reserved_bytes = 0;  // bounds of loads in flight
        uint64_t peak_bytes = 0;      // of resident + reserved + held, since the cache was made
        uint64_t resident_items = 0;
        uint64_t waiting = 0;         // items the last update left unloaded: parent missing, or no room
        uint64_t in_flight = 0;
        uint64_t loaded = 0, evicted = 0, failed = 0;  // since the cache was made
        uint64_t shortfall = 0;       // bytes the last update could not find room for (0: all fitted)
        uint64_t prefetch_waiting = 0;  // prefetched items the last update left unloaded
        uint64_t gpu_budget = 0;          // 0: the GPU's share is capped by `budget` alone
        uint64_t gpu_resident_bytes = 0;  // exact: of resident_bytes, what is on the GPU
        uint64_t held_bytes = 0;          // held beside the items (hold()), counted in the budget too
        uint64_t gpu_held_bytes = 0;      // of those, what is on the GPU
    };

    // Bytes held beside the items while something stays open (a model's per-cube tables), counted in
    // the budget with them (hold()); given back when the handle goes, which must be before the cache.
    class Held {
    public:
        Held() = default;
        Held(Held&& other) noexcept { *this = std::move(other); }
        Held& operator=(Held&& other) noexcept;
        Held(const Held&) = delete;
        Held& operator=(const Held&) = delete;
        ~Held() { release(); }
        uint64_t bytes() const { return bytes_; }
        uint64_t gpu_bytes() const { return gpu_bytes_; }

    private:
        friend class StreamCache;
        void release();
        StreamCache* cache_ = nullptr;
        uint64_t bytes_ = 0, gpu_bytes_ = 0;
    };

    // `loader_threads` ≥ 1. Throws std::invalid_argument on a zero budget.
    StreamCache(uint64_t budget_bytes, unsigned loader_threads);
    ~StreamCache();  // cancels queued loads and waits for those running
    StreamCache(const StreamCache&) = delete;
    StreamCache& operator=(const StreamCache&) = delete;

    // The process's one cache, which streamed models share (one budget for the whole scene): made on
    // first use with a quarter of physical memory and up to 4 loader threads. shared_if_made() is
    // null before that. Models hold it too, so it outlives the last of them, whatever the order in
    // which a process tears down.
    static const std::shared_ptr<StreamCache>& shared();
    static StreamCache* shared_if_made();

    // Adds a source; the table it keeps for the source's items is held in the budget (hold(), which
    // may throw) until remove().
    SourceId add(std::shared_ptr<StreamSource> source);
    // What that table takes for `items` items.
    static uint64_t table_bytes(uint32_t items);
    // Drops the source and its items; its queued loads are cancelled, and those running are discarded
    // when done.
    void remove(SourceId source);

    // Asks for an item for this frame, with a priority (higher first). Its missing ancestors are
    // asked for first, with the same priority. A request lasts until the next update().
    void request(SourceId source, uint32_t item, double priority);
    // Asks for an item a coming frame will want, with a priority among prefetches: it loads after this
    // frame's requests, ancestors first, only where the budget has room free (nothing is evicted for
    // it), and is neither counted by has_requests() nor waited for. Lasts until the next update().
    void prefetch(SourceId source, uint32_t item, double priority);
    // Marks a resident item as used by this frame: not evicted by the next update().
    void touch(SourceId source, uint32_t item);

    // Takes in finished loads, evicts to make room, starts the most wanted requests the budget allows,
    // then ends the frame: requests and touches are cleared.
    void update();
    // Whether this frame asked for something not yet resident.
    bool has_requests() const { return !requests_.empty(); }
    // update() until every item requested this frame is resident; throws std::runtime_error naming
    // the item when a load fails, naming the shortfall when the budget cannot hold them together, and
    // after `timeout_seconds` (≤ 0: no limit). Waits on the loads, not on a clock.
    void wait_for_requests(double timeout_seconds = 0);

    // Counts `bytes` (of which `gpu_bytes` on the GPU) in the budget until the returned handle goes.
    // Evicts the least recently used items to make room, as update() does (so, between frames: render
    // thread); throws std::runtime_error naming `what` and the figures when they do not fit beside the
    // pinned items and what is held already (what it evicted trying stays evicted: it loads again
    // when asked for).
    Held hold(uint64_t bytes, uint64_t gpu_bytes, const std::string& what);

    // Blocks until a load in flight has finished (at once when none is in flight); update() takes it in.
    void wait_for_a_load();

    bool resident(SourceId source, uint32_t item) const;
    // The item's value, or null when it is not resident. Stays valid for the caller as long as it
    // holds the pointer, though it no longer counts once evicted.
    std::shared_ptr<const void> value(SourceId source, uint32_t item) const;
    // The failure of the item's last load, if it failed; a failed item is not loaded again until
    // forget_failure().
    std::optional<std::string> failure(SourceId source, uint32_t item) const;
    void forget_failure(SourceId source, uint32_t item);
    // Counts each update() that changed what is resident of the source (a load came in, an item left).
    uint64_t version(SourceId source) const;

    Stats stats() const;
    uint64_t budget() const { return budget_; }
    // A new budget; each source's pinned items are chosen again for it (StreamSource::pinned_items),
    // and what no longer fits is evicted by the next update() as room is needed. Throws
    // std::invalid_argument on a budget that cannot hold what is held (hold()), leaving it as it was.
    void set_budget(uint64_t budget_bytes);
    // A cap on the GPU's share of the budget on its own (0: none): loads and evictions keep the GPU
    // bytes of resident items, loads in flight and what is held within it too. Throws
    // std::invalid_argument on a cap below what is held on the GPU (hold()).
    void set_gpu_budget(uint64_t gpu_budget_bytes);
    uint64_t gpu_budget() const { return gpu_budget_; }
    // Limits the loaders together to `bytes_per_second` of loaded values (0: no limit), as a disk of
    // that speed would: what a benchmark or a test needs to see loads arrive late.
    void set_load_rate(double bytes_per_second);

private:
    enum class State : uint8_t { absent, loading, resident, failed };
    struct Item {
        State state = State::absent;
        bool pinned = false;
        uint32_t children_held = 0;  // children resident or loading: the item may not leave
        uint64_t bytes = 0;      // actual once resident; the bound while loading
        uint64_t gpu_bytes = 0;  // of those, on the GPU
        uint64_t last_used = 0;
        std::shared_ptr<const void> value;
    };
    struct Source {
        std::shared_ptr<StreamSource> source;
        std::vector<Item> items;
        std::unordered_map<uint32_t, std::string> failures;  // of the items whose state is failed
        Held table;  // what `items` holds, counted in the budget like what the source holds
        uint64_t version = 0;
        std::vector<uint32_t> changed;  // items that came in or left since residency_changed()
        bool removed = false;
    };
    struct Job {
        SourceId source;
        uint32_t item;
        std::shared_ptr<StreamSource> loader;
        std::shared_ptr<const void> parent;
    };
    struct Done {
        SourceId source;
        uint32_t item;
        StreamSource::Loaded loaded;
        std::string failure;
    };
    struct Request {
        SourceId source;
        uint32_t item;
        double priority;
    };

    void loader_loop();
    void take_in_finished();
    // Evicts until `bytes` (of which `gpu_bytes` on the GPU) fit beside what is held; whether they do.
    bool make_room(uint64_t bytes, uint64_t gpu_bytes);
    // What make_room may evict, least recently used first: found on its first need in an update.
    struct Candidate {
        uint64_t last_used;
        SourceId source;
        uint32_t item;
        bool operator>(const Candidate& o) const { return last_used > o.last_used; }
    };
    std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> candidates_;
    bool candidates_found_ = false;
    bool evictable(const Item& it) const;
    void consider(SourceId source, uint32_t item);
    bool fits(uint64_t bytes, uint64_t gpu_bytes) const;
    // Highest priority first; asked in the same order where they tie (an item before its ancestors).
    static void sort_by_priority(std::vector<Request>& asked);
    void start_loads();
    void start_prefetches();
    // Starts loading an absent item whose parent is resident, reserving `bound`; adds its job.
    void start_load(SourceId source, uint32_t item, uint64_t bound, uint64_t gpu_bound, std::vector<Job>& jobs);
    // Tells each source whose residency changed since it was last told (StreamSource::residency_changed).
    void tell_changes();
    void queue_jobs(std::vector<Job>& jobs);
    void evict(SourceId source, uint32_t item);
    // Pins what the source asks to keep under the budget now, and unpins the rest of its items.
    void pin_for_budget(SourceId source);
    // The source, or std::out_of_range when it was removed (or never added).
    const StreamSource& live_source(SourceId source) const;
    Item& item(SourceId source, uint32_t item);
    const Item& item(SourceId source, uint32_t item) const;
    uint64_t used() const { return resident_bytes_ + reserved_bytes_ + held_bytes_; }

    uint64_t budget_, gpu_budget_ = 0;
    std::vector<Source> sources_;  // by SourceId; removed ones stay as empty slots
    std::vector<Request> requests_, prefetches_;
    std::vector<std::pair<SourceId, uint32_t>> pinned_;
    uint64_t frame_ = 1;
    uint64_t resident_bytes_ = 0, reserved_bytes_ = 0, peak_bytes_ = 0, resident_items_ = 0;
    uint64_t gpu_resident_ = 0, gpu_reserved_ = 0;
    uint64_t held_bytes_ = 0, gpu_held_ = 0;
    uint64_t loaded_ = 0, evicted_ = 0, failed_ = 0, shortfall_ = 0, in_flight_ = 0, waiting_ = 0, prefetch_waiting_ = 0;

    // Shared with the loader threads.
    mutable std::mutex mutex_;
    std::condition_variable work_ready_, work_done_;
    std::deque<Job> jobs_;
    std::vector<Done> done_;
    bool stopping_ = false;
    double load_rate_ = 0;
    std::chrono::steady_clock::time_point disk_free_;  // when the throttled "disk" is next free
    std::vector<std::thread> threads_;
};

}  // namespace strata
