// AtomicOutputFile: writes a temporary file beside a target and renames it over the target only once it
// is complete, so readers (and a crash or full disk) never see half a file under the real name. Images,
// paths and the build's job files all go through it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

namespace strata {

class AtomicOutputFile {
public:
    // Creates ".<name>.tmp-<pid>-<n>" in the target's directory. Throws std::runtime_error
    // ("cannot write <target>: <cause>") if it cannot.
    explicit AtomicOutputFile(std::filesystem::path target);
    // Removes the temporary unless commit() put it in place.
    ~AtomicOutputFile();
    AtomicOutputFile(const AtomicOutputFile&) = delete;
    AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;

    // These never throw, because C libraries call them through callbacks: the first failure is kept,
    // later calls do nothing, and commit() reports it.
    void write(const void* data, size_t size) noexcept;
    uint64_t tell() noexcept;
    void seek(uint64_t offset) noexcept;
    bool failed() const noexcept { return first_error_ != 0; }

    // How far commit() pushes the bytes before the rename: to the disk (fsync: the file survives a
    // power cut), or to the kernel only (it survives the process being killed; the build's job files,
    // whose checksums catch what a power cut does, skip a sync per file).
    enum class Sync { to_disk, to_kernel };
    // Flushes, closes and renames over the target. Throws std::runtime_error naming the target and the
    // cause (the first failed write's, e.g. "No space left on device").
    void commit(Sync sync = Sync::to_disk);

    // Throws std::runtime_error("cannot write <target>: <cause>"). A failed write's cause wins over
    // `cause`: a library that gives up after a failed write only reports the consequence.
    [[noreturn]] void fail(const std::string& cause) const;

private:
    void record_failure(int error) noexcept;

    std::filesystem::path target_;
    std::filesystem::path temp_;
    std::FILE* file_ = nullptr;
    int first_error_ = 0;  // errno of the first failed call
    bool committed_ = false;
};

}  // namespace strata
