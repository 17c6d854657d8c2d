// ImageWriter: writes frames (PNG or EXR) on a background thread, so a capture loop renders the next
// frame while the last one is encoded and written. A bounded queue keeps memory in check: write()
// waits while `capacity` frames are pending. Errors are kept and raised by flush().
#pragma once

#include <condition_variable>
#include <deque>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "engine/io/image.h"

namespace strata {

class ImageWriter {
public:
    explicit ImageWriter(size_t capacity = 4);
    // Finishes what is queued; errors not yet raised by flush() are lost, so call flush() first.
    ~ImageWriter();
    ImageWriter(const ImageWriter&) = delete;
    ImageWriter& operator=(const ImageWriter&) = delete;

    // Queues `image` for `path` (.png, or .exr with `channels` and `options`).
    void write(std::shared_ptr<const Image> image, std::filesystem::path path, ImageChannels channels = {},
               ExrOptions options = {});
    // Waits until everything queued is written; throws std::runtime_error with the first failure
    // (and how many more failed) since the last flush.
    void flush();
    size_t pending() const;

private:
    struct Job {
        std::shared_ptr<const Image> image;
        std::filesystem::path path;
        ImageChannels channels;
        ExrOptions options;
    };
    void run();

    const size_t capacity_;
    mutable std::mutex mutex_;
    std::condition_variable changed_;
    std::deque<Job> queue_;
    size_t busy_ = 0;  // jobs taken off the queue and not finished
    std::string first_error_;
    size_t errors_ = 0;
    bool stopping_ = false;
    std::thread thread_;
};

}  // namespace strata
