// One level's cubes on disk between two stages of the builder (000 §3.3.1, the OOM's leaf files):
// blocks append the cubes they make, the next stage reads back the cubes of one block at a time,
// and only the index (key → offset, size) stays in memory: 20 bytes a cube, whatever the scan's size.
#pragma once

#include <atomic>
#include <filesystem>
#include <mutex>
#include <vector>

#include "preprocess/build_cubes.h"
#include "preprocess/scratch_file.h"

namespace strata::build {

class CubeStore {
public:
    // Creates (or empties) `path`; the file is removed when the store is destroyed.
    CubeStore(std::filesystem::path path, DiskUsage& usage);
    CubeStore(const CubeStore&) = delete;
    CubeStore& operator=(const CubeStore&) = delete;

    // Safe from several threads at once. Throws std::runtime_error naming the directory when the
    // disk refuses the bytes (full, read-only).
    void put(const CubeRecord& cube);
    // The cubes' keys in order; call once every put() has returned.
    const std::vector<CubeKey>& keys();
    CubeRecord get(CubeKey key) const;

    uint64_t bytes() const { return end_.load(); }
    uint64_t triangles() const { return triangles_.load(); }
    size_t size() const { return index_.size(); }

private:
    struct Entry {
        CubeKey key;
        uint64_t offset;
        uint32_t size;
    };
    ScratchFile file_;
    std::atomic<uint64_t> end_{0}, triangles_{0};
    std::mutex mutex_;
    std::vector<Entry> index_;
    std::vector<CubeKey> keys_;
    bool sorted_ = false;
};

}  // namespace strata::build
