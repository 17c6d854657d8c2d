#include "preprocess/run_spill.h"

#include <algorithm>

namespace strata::build {

RunSpill::RunSpill(std::filesystem::path path, DiskUsage& usage, uint64_t buffer_bytes, ScratchFile::Lifetime lifetime)
    : file_(std::move(path), usage, lifetime), budget_(std::max<uint64_t>(buffer_bytes, 1 << 20)) {}

RunSpill::RunSpill(std::filesystem::path path, DiskUsage& usage, ByteReader& index)
    : file_(std::move(path), usage, ScratchFile::Lifetime::reopened), budget_(0) {
    const uint64_t runs = index.get<uint64_t>();
    for (uint64_t r = 0; r < runs; ++r) {
        const CubeKey key = index.get<CubeKey>();
        Run& run = runs_[key];
        const uint64_t chunks = index.get<uint64_t>();
        for (uint64_t c = 0; c < chunks; ++c) {
            const Chunk chunk{index.get<uint64_t>(), index.get<uint64_t>()};
            run.chunks.push_back(chunk);
            run.bytes += chunk.size;
        }
        keys_.push_back(key);
    }
    std::sort(keys_.begin(), keys_.end());
}

void RunSpill::append(CubeKey key, const void* bytes, size_t size) {
    const auto* p = static_cast<const uint8_t*>(bytes);
    std::lock_guard lock(mutex_);
    Run& run = runs_[key];
    run.waiting.insert(run.waiting.end(), p, p + size);
    run.bytes += size;
    waiting_ += size;
    peak_waiting_ = std::max(peak_waiting_, waiting_);
    if (waiting_ >= budget_) write_out();
}

// Every waiting run to the end of the file, in key order, so that the file's bytes do not depend on
// the hash table's order.
void RunSpill::write_out() {
    std::vector<CubeKey> waiting;
    for (const auto& [key, run] : runs_)
        if (!run.waiting.empty()) waiting.push_back(key);
    std::sort(waiting.begin(), waiting.end());
    for (CubeKey key : waiting) {
        Run& run = runs_[key];
        file_.write(run.waiting.data(), run.waiting.size(), end_);
        run.chunks.push_back(Chunk{end_, run.waiting.size()});
        end_ += run.waiting.size();
        std::vector<uint8_t>().swap(run.waiting);
    }
    waiting_ = 0;
}

void RunSpill::finish() {
    std::lock_guard lock(mutex_);
    write_out();
    keys_.clear();
    for (const auto& [key, run] : runs_) keys_.push_back(key);
    std::sort(keys_.begin(), keys_.end());
}

std::vector<uint8_t> RunSpill::read(CubeKey key) const {
    const auto it = runs_.find(key);
    if (it == runs_.end()) return {};
    std::vector<uint8_t> bytes(it->second.bytes);
    size_t at = 0;
    for (const Chunk& chunk : it->second.chunks) {
        file_.read(bytes.data() + at, chunk.size, chunk.offset);
        at += chunk.size;
    }
    return bytes;
}

void RunSpill::save_index(ByteWriter& out) const {
    out.put(uint64_t(keys_.size()));
    for (CubeKey key : keys_) {
        const Run& run = runs_.at(key);
        out.put(key);
        out.put(uint64_t(run.chunks.size()));
        for (const Chunk& chunk : run.chunks) out.put(chunk.offset), out.put(chunk.size);
    }
}

void RunSpill::release(CubeKey key) {
    const auto it = runs_.find(key);
    if (it == runs_.end()) return;
    for (const Chunk& chunk : it->second.chunks) file_.release(chunk.offset, chunk.size);
}

}  // namespace strata::build
