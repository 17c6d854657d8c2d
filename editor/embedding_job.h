// An embedding file made on a worker thread (the Inspector's Embed and Move, ed:embed, ed:move), so
// that the window stays live while a large site is embedded, shows how far the work is and can cancel
// it. Only the file is made there (preprocessing: no node, no GL); the UI thread puts it in the scene
// once it is done.
#pragma once

#include <atomic>
#include <chrono>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "preprocess/progress.h"

namespace strata {

class EmbeddingJob {
public:
    // Runs `make` on a thread of its own, with a Progress that reports here and checks cancel().
    EmbeddingJob(std::string title, std::function<void(const Progress&)> make);
    ~EmbeddingJob();  // cancels the work and waits for it
    EmbeddingJob(const EmbeddingJob&) = delete;
    EmbeddingJob& operator=(const EmbeddingJob&) = delete;

    const std::string& title() const { return title_; }
    bool finished() const { return finished_.load(std::memory_order_acquire); }
    void wait();
    void cancel() { cancel_.store(true); }
    // Once finished: rethrows what `make` threw (Cancelled when it was cancelled).
    void rethrow() const;

    struct Status {
        std::string stage;     // what runs now ("simplify level 3", "skirt textures")
        double fraction = -1;  // of the stage, 0…1; below 0 when it gives no total
        double seconds = 0;    // since the job began
    };
    Status status() const;

private:
    void report(std::string_view stage, double done, double total);

    const std::string title_;
    const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    std::atomic<bool> cancel_{false}, finished_{false};
    mutable std::mutex mutex_;  // guards stage_ and fraction_
    std::string stage_;
    double fraction_ = -1;
    std::exception_ptr error_;  // written by the worker before finished_
    std::thread worker_;
};

}  // namespace strata
