// Runs of records keyed by block, larger than memory (000 §3.3.1's out-of-core leaf files, in one
// file): appends wait in memory up to a budget, then every waiting run goes to the end of one
// temporary file as a chunk; a run reads back as its chunks in order. What reads back does not
// depend on the budget, so neither does anything built from it. A kept spill outlives its process:
// its index, saved with the build's plan, opens it again in the jobs that read it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "preprocess/build_cubes.h"
#include "preprocess/byte_packing.h"
#include "preprocess/scratch_file.h"

namespace strata::build {

class RunSpill {
public:
    // Creates (or empties) `path`, removed with the spill. At most `buffer_bytes` wait in memory.
    RunSpill(std::filesystem::path path, DiskUsage& usage, uint64_t buffer_bytes,
             ScratchFile::Lifetime lifetime = ScratchFile::Lifetime::temporary);
    // A kept spill opened again, finished, from the index save_index() wrote. Throws std::runtime_error
    // (from the reader) when the index is cut short.
    RunSpill(std::filesystem::path path, DiskUsage& usage, ByteReader& index);
    RunSpill(const RunSpill&) = delete;
    RunSpill& operator=(const RunSpill&) = delete;

    // Safe from several threads at once; appends to one key from one thread keep their order.
    void append(CubeKey key, const void* bytes, size_t size);
    // Writes out what waits; then keys() and read() may be called, from several threads.
    void finish();
    const std::vector<CubeKey>& keys() const { return keys_; }
    // The run's bytes in order, or nothing for a key without one.
    std::vector<uint8_t> read(CubeKey key) const;
    // Gives the disk back a run's bytes once it has been read for the last time.
    void release(CubeKey key);
    // After finish(): where every run lies in the file.
    void save_index(ByteWriter& out) const;

    uint64_t memory_bytes() const { return peak_waiting_; }  // the most that waited in memory

private:
    struct Chunk {
        uint64_t offset, size;
    };
    struct Run {
        std::vector<uint8_t> waiting;
        std::vector<Chunk> chunks;
        uint64_t bytes = 0;
    };
    void write_out();

    ScratchFile file_;
    uint64_t budget_;
    std::mutex mutex_;
    std::unordered_map<CubeKey, Run> runs_;
    std::vector<CubeKey> keys_;
    uint64_t waiting_ = 0, peak_waiting_ = 0, end_ = 0;
};

}  // namespace strata::build
