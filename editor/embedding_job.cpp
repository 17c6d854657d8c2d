#include "editor/embedding_job.h"

#include <algorithm>

namespace strata {

EmbeddingJob::EmbeddingJob(std::string title, std::function<void(const Progress&)> make) : title_(std::move(title)) {
    worker_ = std::thread([this, make = std::move(make)] {
        Progress progress;
        progress.report = [this](std::string_view stage, double done, double total, std::string_view) { report(stage, done, total); };
        progress.cancel = &cancel_;
        try {
            make(progress);
        } catch (...) {
            error_ = std::current_exception();
        }
        finished_.store(true, std::memory_order_release);
    });
}

EmbeddingJob::~EmbeddingJob() {
    cancel();
    wait();
}

void EmbeddingJob::wait() {
    if (worker_.joinable()) worker_.join();
}

void EmbeddingJob::rethrow() const {
    if (error_) std::rethrow_exception(error_);
}

void EmbeddingJob::report(std::string_view stage, double done, double total) {
    const std::lock_guard lock(mutex_);
    if (stage_ != stage) stage_ = stage;
    fraction_ = total > 0 ? std::min(done / total, 1.0) : -1;
}

EmbeddingJob::Status EmbeddingJob::status() const {
    const std::lock_guard lock(mutex_);
    return {stage_, fraction_, std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count()};
}

}  // namespace strata
