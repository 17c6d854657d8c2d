#include "preprocess/scratch_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace strata::build {

namespace {

int open_flags(ScratchFile::Lifetime lifetime) {
    return lifetime == ScratchFile::Lifetime::reopened ? O_RDWR | O_CLOEXEC : O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC;
}

}  // namespace

ScratchFile::ScratchFile(std::filesystem::path path, DiskUsage& usage, Lifetime lifetime)
    : path_(std::move(path)), file_(::open(path_.c_str(), open_flags(lifetime), 0600)), usage_(usage), lifetime_(lifetime) {
    if (file_.get() < 0) fail(lifetime == Lifetime::reopened ? "cannot open" : "cannot create", errno);
}

ScratchFile::~ScratchFile() {
    if (lifetime_ != Lifetime::temporary) return;
    usage_.remove(held_.load());
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
}

void ScratchFile::fail(const char* what, int error) const {
    throw std::runtime_error(path_.parent_path().string() + ": " + what + " the build's temporary file " +
                             path_.filename().string() + " (" + std::strerror(error) + ")");
}

void ScratchFile::write(const void* data, size_t size, uint64_t offset) {
    const auto* bytes = static_cast<const char*>(data);
    for (size_t done = 0; done < size;) {
        const ssize_t n = ::pwrite(file_.get(), bytes + done, size - done, off_t(offset + done));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) fail("cannot write", n < 0 ? errno : ENOSPC);
        done += size_t(n);
    }
    held_ += size;
    usage_.add(size);
}

void ScratchFile::read(void* data, size_t size, uint64_t offset) const {
    if (!read_fully(file_.get(), offset, data, size)) fail("cannot read back", errno ? errno : EIO);
}

void ScratchFile::release(uint64_t offset, uint64_t size) {
    // A file system that cannot punch holes keeps the bytes until the file is removed, and they count.
    if (::fallocate(file_.get(), FALLOC_FL_PUNCH_HOLE | FALLOC_FL_KEEP_SIZE, off_t(offset), off_t(size)) != 0) return;
    if (lifetime_ == Lifetime::temporary) held_ -= size;
    usage_.remove(size);
}

}  // namespace strata::build
