// One of the build's temporary files (a level's cubes, the triangle spill, border listings): created
// empty, written and read at offsets from several threads, removed when destroyed. A disk that
// refuses bytes is a std::runtime_error naming the folder, which is what the user must free. The
// files of one build count their bytes together, so the build can report its peak temporary disk.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "preprocess/hlod_format.h"

namespace strata::build {

// Bytes on disk of a build's temporary files, now and at the most.
class DiskUsage {
public:
    void add(uint64_t bytes) {
        const uint64_t now = live_ += bytes;
        uint64_t peak = peak_.load();
        while (now > peak && !peak_.compare_exchange_weak(peak, now)) {
        }
    }
    void remove(uint64_t bytes) { live_ -= bytes; }
    uint64_t peak() const { return peak_.load(); }

private:
    std::atomic<uint64_t> live_{0}, peak_{0};
};

class ScratchFile {
public:
    enum class Lifetime {
        temporary,  // created empty, removed when destroyed
        kept,       // created empty, left in place for later jobs (the plan's triangle spill)
        reopened,   // a kept file opened again to read (its bytes counted where the build began)
    };
    ScratchFile(std::filesystem::path path, DiskUsage& usage, Lifetime lifetime = Lifetime::temporary);
    ~ScratchFile();
    ScratchFile(const ScratchFile&) = delete;
    ScratchFile& operator=(const ScratchFile&) = delete;

    // Writes at `offset`, which must lie past everything written so far that is still held.
    void write(const void* data, size_t size, uint64_t offset);
    void read(void* data, size_t size, uint64_t offset) const;
    // Gives the disk back the bytes [offset, offset + size), which are not read again.
    void release(uint64_t offset, uint64_t size);

private:
    [[noreturn]] void fail(const char* what, int error) const;
    std::filesystem::path path_;
    FileHandle file_;
    DiskUsage& usage_;
    Lifetime lifetime_;
    std::atomic<uint64_t> held_{0};
};

}  // namespace strata::build
