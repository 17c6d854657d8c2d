#include "engine/io/image_writer.h"

#include <stdexcept>

namespace strata {

ImageWriter::ImageWriter(size_t capacity) : capacity_(capacity == 0 ? 1 : capacity), thread_([this] { run(); }) {}

ImageWriter::~ImageWriter() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    changed_.notify_all();
    thread_.join();
}

void ImageWriter::write(std::shared_ptr<const Image> image, std::filesystem::path path, ImageChannels channels,
                        ExrOptions options) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return queue_.size() < capacity_; });
    queue_.push_back({std::move(image), std::move(path), channels, options});
    changed_.notify_all();
}

void ImageWriter::flush() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return queue_.empty() && busy_ == 0; });
    if (errors_ == 0) return;
    std::string message = first_error_;
    if (errors_ > 1) message += " (and " + std::to_string(errors_ - 1) + " more frames failed)";
    first_error_.clear();
    errors_ = 0;
    throw std::runtime_error(message);
}

size_t ImageWriter::pending() const {
    std::lock_guard lock(mutex_);
    return queue_.size() + busy_;
}

void ImageWriter::run() {
    std::unique_lock lock(mutex_);
    for (;;) {
        changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (queue_.empty()) return;  // stopping, and nothing left
        Job job = std::move(queue_.front());
        queue_.pop_front();
        ++busy_;
        changed_.notify_all();  // room in the queue
        lock.unlock();
        std::string error;
        try {
            if (job.path.extension() == ".png") write_png(*job.image, job.path);
            else write_exr(*job.image, job.path, job.channels, job.options);
        } catch (const std::exception& e) {
            error = e.what();
        }
        lock.lock();
        --busy_;
        if (!error.empty() && errors_++ == 0) first_error_ = error;
        changed_.notify_all();
    }
}

}  // namespace strata
