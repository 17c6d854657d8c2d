#include "engine/stream/stream_cache.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>
#include <stdexcept>
#include <utility>

#include "preprocess/byte_size.h"

namespace strata {

namespace {
std::mutex shared_mutex;
std::shared_ptr<StreamCache> shared_cache;
}  // namespace

const std::shared_ptr<StreamCache>& StreamCache::shared() {
    const std::lock_guard lock(shared_mutex);
    if (!shared_cache) shared_cache = std::make_shared<StreamCache>(default_memory_limit(), std::clamp(std::thread::hardware_concurrency(), 1u, 4u));
    return shared_cache;
}

StreamCache* StreamCache::shared_if_made() {
    const std::lock_guard lock(shared_mutex);
    return shared_cache.get();
}

StreamCache::StreamCache(uint64_t budget_bytes, unsigned loader_threads) : budget_(budget_bytes) {
    if (budget_bytes == 0) throw std::invalid_argument("the streaming budget must be positive");
    for (unsigned t = 0; t < std::max(1u, loader_threads); ++t) threads_.emplace_back([this] { loader_loop(); });
}

StreamCache::~StreamCache() {
    {
        const std::lock_guard lock(mutex_);
        stopping_ = true;
        jobs_.clear();
    }
    work_ready_.notify_all();
    for (std::thread& t : threads_) t.join();
    sources_.clear();  // their tables' handles give their bytes back while the counts still stand
}

StreamCache::SourceId StreamCache::add(std::shared_ptr<StreamSource> source) {
    Source entry;
    const uint32_t items = source->item_count();
    entry.table = hold(table_bytes(items), 0, "the cache's table of " + std::to_string(items) + " items");
    entry.items.resize(items);
    entry.source = std::move(source);
    sources_.push_back(std::move(entry));
    const SourceId id(sources_.size() - 1);
    pin_for_budget(id);
    return id;
}

void StreamCache::pin_for_budget(SourceId id) {
    Source& s = sources_[id];
    for (Item& it : s.items) it.pinned = false;
    std::erase_if(pinned_, [&](const auto& p) { return p.first == id; });
    for (const uint32_t index : s.source->pinned_items(budget_)) {
        Item& it = s.items.at(index);
        if (it.pinned) continue;
        it.pinned = true;
        pinned_.push_back({id, index});
    }
}

void StreamCache::remove(SourceId id) {
    Source& s = sources_.at(id);
    {
        const std::lock_guard lock(mutex_);
        in_flight_ -= std::erase_if(jobs_, [&](const Job& job) { return job.source == id; });
    }
    for (const Item& it : s.items) {
        if (it.state == State::resident) resident_bytes_ -= it.bytes, gpu_resident_ -= it.gpu_bytes, --resident_items_;
        if (it.state == State::loading) reserved_bytes_ -= it.bytes, gpu_reserved_ -= it.gpu_bytes;  // a running load is discarded when done
    }
    s.removed = true;
    s.source.reset();  // what it holds goes with it (loads still running keep it until they end)
    s.items = {};
    s.failures = {};
    s.table = {};
    s.changed.clear();
    std::erase_if(pinned_, [&](const auto& p) { return p.first == id; });
}

uint64_t StreamCache::table_bytes(uint32_t items) { return uint64_t(items) * sizeof(Item); }

StreamCache::Item& StreamCache::item(SourceId source, uint32_t index) { return sources_.at(source).items.at(index); }
const StreamCache::Item& StreamCache::item(SourceId source, uint32_t index) const { return sources_.at(source).items.at(index); }

const StreamSource& StreamCache::live_source(SourceId source) const {
    const Source& s = sources_.at(source);
    if (s.removed) throw std::out_of_range("streaming: source " + std::to_string(source) + " was removed");
    return *s.source;
}

void StreamCache::request(SourceId source, uint32_t index, double priority) {
    const StreamSource& s = live_source(source);
    for (uint32_t i = index; i != StreamSource::kNoItem; i = s.parent(i)) {
        Item& it = item(source, i);
        it.last_used = frame_;  // what the frame asks for, and the ancestors it needs, stay
        if (it.state != State::resident) requests_.push_back({source, i, priority});
    }
}

void StreamCache::prefetch(SourceId source, uint32_t index, double priority) {
    const StreamSource& s = live_source(source);
    for (uint32_t i = index; i != StreamSource::kNoItem; i = s.parent(i))
        if (item(source, i).state != State::resident) prefetches_.push_back({source, i, priority});
}

void StreamCache::touch(SourceId source, uint32_t index) { item(source, index).last_used = frame_; }

void StreamCache::loader_loop() {
    for (;;) {
        Job job;
        {
            std::unique_lock lock(mutex_);
            work_ready_.wait(lock, [&] { return stopping_ || !jobs_.empty(); });
            if (stopping_) return;
            job = std::move(jobs_.front());
            jobs_.pop_front();
        }
        Done done{job.source, job.item, {}, {}};
        try {
            done.loaded = job.loader->load(job.item, job.parent);
            if (!done.loaded.value) done.failure = "a load gave nothing";
        } catch (const std::exception& e) {
            done.failure = e.what();
            if (done.failure.empty()) done.failure = "a load failed";
        }
        job = {};  // lets go of the source and the parent before the load is seen to end
        {
            std::unique_lock lock(mutex_);
            if (load_rate_ > 0) {  // the loads take turns on one "disk", each for its bytes' time
                const auto now = std::chrono::steady_clock::now();
                disk_free_ = std::max(disk_free_, now) +
                             std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                 std::chrono::duration<double>(double(done.loaded.bytes) / load_rate_));
                const auto until = disk_free_;
                if (work_ready_.wait_until(lock, until, [&] { return stopping_; })) return;
            }
            done_.push_back(std::move(done));
        }
        work_done_.notify_all();
    }
}

void StreamCache::take_in_finished() {
    std::vector<Done> finished;
    {
        const std::lock_guard lock(mutex_);
        finished.swap(done_);
    }
    for (Done& d : finished) {
        --in_flight_;
        Source& s = sources_[d.source];
        if (s.removed) continue;  // its reservation went with the source
        Item& it = s.items[d.item];
        reserved_bytes_ -= it.bytes;
        gpu_reserved_ -= it.gpu_bytes;
        const uint32_t parent = s.source->parent(d.item);
        if (d.failure.empty() && d.loaded.bytes > it.bytes)
            d.failure = "a load took " + std::to_string(d.loaded.bytes) + " bytes, more than its bound of " + std::to_string(it.bytes);
        if (d.failure.empty() && (d.loaded.gpu_bytes > it.gpu_bytes || d.loaded.gpu_bytes > d.loaded.bytes))
            d.failure = "a load took " + std::to_string(d.loaded.gpu_bytes) + " bytes of GPU memory, more than its bound of " +
                        std::to_string(it.gpu_bytes);
        if (!d.failure.empty()) {
            it.state = State::failed;
            s.failures[d.item] = std::move(d.failure);
            if (parent != StreamSource::kNoItem) --s.items[parent].children_held;
            ++failed_;
            continue;
        }
        it.state = State::resident;
        it.value = std::move(d.loaded.value);
        it.bytes = d.loaded.bytes;
        it.gpu_bytes = d.loaded.gpu_bytes;
        resident_bytes_ += it.bytes;
        gpu_resident_ += it.gpu_bytes;
        ++resident_items_;
        ++loaded_;
        ++s.version;
        s.changed.push_back(d.item);
    }
}

void StreamCache::evict(SourceId source, uint32_t index) {
    Source& s = sources_[source];
    Item& it = s.items[index];
    it.state = State::absent;
    it.value.reset();
    resident_bytes_ -= it.bytes;
    gpu_resident_ -= it.gpu_bytes;
    --resident_items_;
    ++evicted_;
    ++s.version;
    s.changed.push_back(index);
    if (const uint32_t parent = s.source->parent(index); parent != StreamSource::kNoItem) --s.items[parent].children_held;
}

bool StreamCache::fits(uint64_t bytes, uint64_t gpu_bytes) const {
    return used() + bytes <= budget_ && (gpu_budget_ == 0 || gpu_resident_ + gpu_reserved_ + gpu_held_ + gpu_bytes <= gpu_budget_);
}

bool StreamCache::evictable(const Item& it) const {
    return it.state == State::resident && !it.pinned && it.children_held == 0 && it.last_used < frame_;
}

void StreamCache::consider(SourceId source, uint32_t index) {
    if (const Item& it = sources_[source].items[index]; evictable(it)) candidates_.push({it.last_used, source, index});
}

bool StreamCache::make_room(uint64_t bytes, uint64_t gpu_bytes) {
    if (fits(bytes, gpu_bytes)) return true;
    // Least recently used first, among resident items nothing holds: not pinned, no child resident
    // or loading, not used by this frame. Evicting a child may free its parent, which then joins.
    // The candidates are found once per update, not once per load that needs room (a pass over every
    // item of ten open 300 M-triangle models is 3 M steps); each is checked again when its turn
    // comes, since loads started since then may hold it.
    if (!candidates_found_) {
        candidates_ = {};
        for (SourceId s = 0; s < sources_.size(); ++s)
            for (uint32_t i = 0; i < sources_[s].items.size(); ++i) consider(s, i);
        candidates_found_ = true;
    }
    while (!fits(bytes, gpu_bytes) && !candidates_.empty()) {
        const Candidate c = candidates_.top();
        candidates_.pop();
        const Source& s = sources_[c.source];
        if (s.removed || !evictable(s.items[c.item]) || s.items[c.item].last_used != c.last_used) continue;
        evict(c.source, c.item);
        if (const uint32_t parent = s.source->parent(c.item); parent != StreamSource::kNoItem) consider(c.source, parent);
    }
    return fits(bytes, gpu_bytes);
}

void StreamCache::sort_by_priority(std::vector<Request>& asked) {
    std::stable_sort(asked.begin(), asked.end(), [](const Request& a, const Request& b) { return a.priority > b.priority; });
}

void StreamCache::start_loads() {
    for (const auto& [source, index] : pinned_) request(source, index, INFINITY);
    sort_by_priority(requests_);
    shortfall_ = waiting_ = 0;
    std::vector<Job> jobs;
    for (const Request& r : requests_) {
        Source& s = sources_[r.source];
        if (s.removed) continue;
        Item& it = s.items[r.item];
        if (it.state != State::absent) continue;  // loading, resident, failed, or asked twice
        const uint32_t parent = s.source->parent(r.item);
        if (parent != StreamSource::kNoItem && s.items[parent].state != State::resident) {
            ++waiting_;  // next time, after its parent
            continue;
        }
        const uint64_t bound = s.source->item_bytes(r.item), gpu_bound = s.source->item_gpu_bytes(r.item);
        if (!make_room(bound, gpu_bound)) {
            shortfall_ += bound;
            ++waiting_;
            continue;
        }
        start_load(r.source, r.item, bound, gpu_bound, jobs);
    }
    queue_jobs(jobs);
}

void StreamCache::start_prefetches() {
    sort_by_priority(prefetches_);
    prefetch_waiting_ = 0;
    std::vector<Job> jobs;
    for (const Request& r : prefetches_) {
        Source& s = sources_[r.source];
        if (s.removed || s.items[r.item].state != State::absent) continue;
        const uint32_t parent = s.source->parent(r.item);
        const uint64_t bound = s.source->item_bytes(r.item), gpu_bound = s.source->item_gpu_bytes(r.item);
        if ((parent != StreamSource::kNoItem && s.items[parent].state != State::resident) || !fits(bound, gpu_bound)) {
            ++prefetch_waiting_;
            continue;
        }
        // Counted as used now, so that the next frame's requests do not evict it first as the least
        // recently used of all.
        s.items[r.item].last_used = frame_;
        start_load(r.source, r.item, bound, gpu_bound, jobs);
    }
    queue_jobs(jobs);
}

void StreamCache::start_load(SourceId source, uint32_t index, uint64_t bound, uint64_t gpu_bound, std::vector<Job>& jobs) {
    Source& s = sources_[source];
    Item& it = s.items[index];
    const uint32_t parent = s.source->parent(index);
    it.state = State::loading;
    it.bytes = bound;
    it.gpu_bytes = gpu_bound;
    reserved_bytes_ += bound;
    gpu_reserved_ += gpu_bound;
    peak_bytes_ = std::max(peak_bytes_, used());
    ++in_flight_;
    if (parent != StreamSource::kNoItem) ++s.items[parent].children_held;
    jobs.push_back({source, index, s.source, parent == StreamSource::kNoItem ? nullptr : s.items[parent].value});
}

void StreamCache::tell_changes() {
    for (Source& s : sources_) {
        if (s.removed || s.changed.empty()) continue;
        const std::vector<uint32_t> changed = std::exchange(s.changed, {});
        s.source->residency_changed(changed, s.version);
    }
}

void StreamCache::queue_jobs(std::vector<Job>& jobs) {
    tell_changes();  // what evictions freed goes before the loads take more; arrivals are told too
    if (jobs.empty()) return;
    {
        const std::lock_guard lock(mutex_);
        for (Job& job : jobs) jobs_.push_back(std::move(job));
    }
    work_ready_.notify_all();
}

void StreamCache::update() {
    candidates_found_ = false;
    take_in_finished();
    make_room(0, 0);  // a lowered budget
    start_loads();
    start_prefetches();
    requests_.clear();
    prefetches_.clear();
    ++frame_;
}

void StreamCache::wait_for_requests(double timeout_seconds) {
    using Clock = std::chrono::steady_clock;
    const auto start = Clock::now();
    const std::vector<Request> wanted = requests_;
    for (;;) {
        requests_ = wanted;
        candidates_found_ = false;
        take_in_finished();
        make_room(0, 0);
        start_loads();
        uint64_t missing = 0;
        for (const Request& r : wanted) {
            const Source& s = sources_[r.source];
            if (s.removed) continue;
            const Item& it = s.items[r.item];
            if (it.state == State::failed) throw std::runtime_error(s.failures.at(r.item));
            missing += it.state != State::resident;
        }
        if (missing == 0) break;
        if (in_flight_ == 0)  // nothing will come: what is wanted does not fit beside what it needs
            throw std::runtime_error("the view needs more than the streaming budget of " + describe_bytes(budget_) +
                                     (gpu_budget_ ? " (" + describe_bytes(gpu_budget_) + " of it on the GPU)" : std::string()) + " holds: " +
                                     std::to_string(missing) + " of its items do not fit beside the rest (" +
                                     describe_bytes(shortfall_) + " short)");
        std::unique_lock lock(mutex_);
        const auto ready = [&] { return !done_.empty(); };
        if (timeout_seconds > 0) {
            const auto deadline = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_seconds));
            if (!work_done_.wait_until(lock, deadline, ready))
                throw std::runtime_error("the view's items were not all loaded after " + std::to_string(timeout_seconds) +
                                         " s (" + std::to_string(missing) + " missing)");
        } else {
            work_done_.wait(lock, ready);
        }
    }
    requests_.clear();
    prefetches_.clear();  // the frame is over: its next cull asks again
    ++frame_;
}

void StreamCache::set_gpu_budget(uint64_t gpu_budget_bytes) {
    if (gpu_budget_bytes != 0 && gpu_budget_bytes < gpu_held_)
        throw std::invalid_argument("a GPU budget of " + describe_bytes(gpu_budget_bytes) + " cannot hold the " + describe_bytes(gpu_held_) +
                                    " that the open models' tables take on the GPU");
    gpu_budget_ = gpu_budget_bytes;
}

StreamCache::Held StreamCache::hold(uint64_t bytes, uint64_t gpu_bytes, const std::string& what) {
    candidates_found_ = false;
    if (!make_room(bytes, gpu_bytes)) {
        const uint64_t others = held_bytes_, pinned = resident_bytes_ + reserved_bytes_;
        tell_changes();
        throw std::runtime_error(what + " take " + describe_bytes(bytes) + ", which do not fit in the streaming budget of " +
                                 describe_bytes(budget_) + (gpu_budget_ ? " (" + describe_bytes(gpu_budget_) + " of it on the GPU)" : std::string()) +
                                 " beside the " + describe_bytes(others) + " that open models' tables take and the " + describe_bytes(pinned) +
                                 " of items that cannot leave: raise --memory");
    }
    tell_changes();  // what left to make room goes now
    held_bytes_ += bytes;
    gpu_held_ += gpu_bytes;
    peak_bytes_ = std::max(peak_bytes_, used());
    Held held;
    held.cache_ = this;
    held.bytes_ = bytes;
    held.gpu_bytes_ = gpu_bytes;
    return held;
}

StreamCache::Held& StreamCache::Held::operator=(Held&& other) noexcept {
    if (this != &other) {
        release();
        cache_ = std::exchange(other.cache_, nullptr);
        bytes_ = std::exchange(other.bytes_, 0);
        gpu_bytes_ = std::exchange(other.gpu_bytes_, 0);
    }
    return *this;
}

void StreamCache::Held::release() {
    if (!cache_) return;
    cache_->held_bytes_ -= bytes_;
    cache_->gpu_held_ -= gpu_bytes_;
    cache_ = nullptr;
}

void StreamCache::wait_for_a_load() {
    std::unique_lock lock(mutex_);
    work_done_.wait(lock, [&] { return !done_.empty() || in_flight_ == 0; });
}

bool StreamCache::resident(SourceId source, uint32_t index) const { return item(source, index).state == State::resident; }

std::shared_ptr<const void> StreamCache::value(SourceId source, uint32_t index) const { return item(source, index).value; }

std::optional<std::string> StreamCache::failure(SourceId source, uint32_t index) const {
    const Item& it = item(source, index);
    if (it.state != State::failed) return std::nullopt;
    return sources_.at(source).failures.at(index);
}

void StreamCache::forget_failure(SourceId source, uint32_t index) {
    Item& it = item(source, index);
    if (it.state != State::failed) return;
    it.state = State::absent;
    sources_.at(source).failures.erase(index);
}

uint64_t StreamCache::version(SourceId source) const { return sources_.at(source).version; }

StreamCache::Stats StreamCache::stats() const {
    Stats s;
    s.budget = budget_;
    s.resident_bytes = resident_bytes_;
    s.reserved_bytes = reserved_bytes_;
    s.peak_bytes = peak_bytes_;
    s.resident_items = resident_items_;
    s.waiting = waiting_;
    s.in_flight = in_flight_;
    s.loaded = loaded_, s.evicted = evicted_, s.failed = failed_, s.shortfall = shortfall_;
    s.prefetch_waiting = prefetch_waiting_;
    s.gpu_budget = gpu_budget_;
    s.gpu_resident_bytes = gpu_resident_;
    s.held_bytes = held_bytes_;
    s.gpu_held_bytes = gpu_held_;
    return s;
}

void StreamCache::set_load_rate(double bytes_per_second) {
    const std::lock_guard lock(mutex_);
    load_rate_ = std::isfinite(bytes_per_second) && bytes_per_second > 0 ? bytes_per_second : 0;
}

void StreamCache::set_budget(uint64_t budget_bytes) {
    if (budget_bytes == 0) throw std::invalid_argument("the streaming budget must be positive");
    if (budget_bytes < held_bytes_)
        throw std::invalid_argument("a streaming budget of " + describe_bytes(budget_bytes) + " cannot hold the " + describe_bytes(held_bytes_) +
                                    " that the open models' tables take");
    budget_ = budget_bytes;
    for (SourceId id = 0; id < sources_.size(); ++id)
        if (!sources_[id].removed) pin_for_budget(id);
}

}  // namespace strata
