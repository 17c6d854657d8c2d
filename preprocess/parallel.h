// A parallel for over [0, count) on std::threads. Items are handed out one at a time from an atomic
// counter, so uneven items (blocks of very different sizes) balance; results go to per-item slots, which
// keeps output independent of the thread count. The first exception thrown by any item is rethrown.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace strata {

inline unsigned resolve_thread_count(int requested) {
    if (requested > 0) return unsigned(requested);
    unsigned hardware = std::thread::hardware_concurrency();
    return hardware ? hardware : 1;
}

// fn(item, worker): worker in [0, threads) indexes per-thread scratch.
template <class Fn>
void parallel_for(size_t count, unsigned threads, Fn&& fn) {
    threads = unsigned(std::min<size_t>(std::max(1u, threads), std::max<size_t>(count, 1)));
    std::atomic<size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    auto work = [&](unsigned worker) {
        for (size_t i; (i = next.fetch_add(1, std::memory_order_relaxed)) < count;) {
            try {
                fn(i, worker);
            } catch (...) {
                std::lock_guard lock(failure_mutex);
                if (!failure) failure = std::current_exception();
                next.store(count);  // stop handing out work
            }
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work, t);
    work(0);
    for (std::thread& t : pool) t.join();
    if (failure) std::rethrow_exception(failure);
}

}  // namespace strata
