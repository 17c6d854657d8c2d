// AtomicOutputFile: a temporary file beside the target, renamed over it once complete.
#include "preprocess/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>
#include <utility>

namespace strata {

AtomicOutputFile::AtomicOutputFile(std::filesystem::path target) : target_(std::move(target)) {
    // Unique per process and per call, so concurrent writers of one target never share a temporary.
    static std::atomic<unsigned> counter{0};
    std::string leaf = "." + target_.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                       std::to_string(counter.fetch_add(1));
    temp_ = target_.parent_path() / leaf;
    file_ = std::fopen(temp_.c_str(), "wbx");
    if (!file_) fail(std::strerror(errno));
    std::setvbuf(file_, nullptr, _IOFBF, size_t(1) << 20);
}

AtomicOutputFile::~AtomicOutputFile() {
    if (file_) std::fclose(file_);
    if (!committed_) {
        std::error_code ignored;
        std::filesystem::remove(temp_, ignored);
    }
}

void AtomicOutputFile::record_failure(int error) noexcept {
    if (first_error_ == 0) first_error_ = error ? error : EIO;
}

void AtomicOutputFile::write(const void* data, size_t size) noexcept {
    if (first_error_ || size == 0) return;
    if (std::fwrite(data, 1, size, file_) != size) record_failure(errno);
}

uint64_t AtomicOutputFile::tell() noexcept {
    off_t offset = ::ftello(file_);
    if (offset < 0) record_failure(errno);
    return offset < 0 ? 0 : uint64_t(offset);
}

void AtomicOutputFile::seek(uint64_t offset) noexcept {
    if (first_error_) return;
    if (::fseeko(file_, off_t(offset), SEEK_SET) != 0) record_failure(errno);
}

void AtomicOutputFile::commit(Sync sync) {
    // stdio buffers: a full disk often shows only when the buffer is flushed, here.
    if (!first_error_ && std::fflush(file_) != 0) record_failure(errno);
    if (!first_error_ && sync == Sync::to_disk && ::fsync(::fileno(file_)) != 0) record_failure(errno);
    const int closed = std::fclose(file_);
    file_ = nullptr;
    if (closed != 0) record_failure(errno);
    if (first_error_) fail("write failed");
    std::error_code ec;
    std::filesystem::rename(temp_, target_, ec);
    if (ec) fail(ec.message());
    committed_ = true;
}

void AtomicOutputFile::fail(const std::string& cause) const {
    const std::string reason = failed() ? std::strerror(first_error_) : cause;
    throw std::runtime_error("cannot write " + target_.string() + ": " + reason);
}

}  // namespace strata
