// Fuzz target: the .hlod reader (preprocess/hlod_format.cpp) as `strata verify` and the viewer use it:
// open the file (header, node table), decode every cube's payload, then check the model as
// `strata verify` does. Properties: every failure is a std::runtime_error naming the file; nothing
// crashes or allocates without bound.
//
// The input is a .hlod file. A mutated byte would almost always break a CRC-32C and stop the reader at
// the first check, so before the file is written its checksums are recomputed wherever its structure
// lets them be found (payloads, node table, header; FORMAT.md). The reader itself is unchanged, and the
// same inputs replay the same way in the ordinary build.
#include <cstring>
#include <stdexcept>
#include <vector>

#include "preprocess/hlod_format.h"
#include "preprocess/hlod_verify.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

// FORMAT.md §3–4.
constexpr size_t kHeaderBytes = 128;
constexpr size_t kNodeCountAt = 88, kNodeTableOffsetAt = 96, kHeaderCrcAt = 104;
constexpr size_t kNodeBytes = 48, kNodeChecksumAt = 28, kNodeOffsetAt = 32, kNodeSizeAt = 40;

template <class T>
T load(const std::vector<uint8_t>& bytes, size_t at) {
    T value;
    std::memcpy(&value, bytes.data() + at, sizeof(T));
    return value;
}

void store_crc(std::vector<uint8_t>& bytes, size_t at, size_t begin, size_t end) {
    const uint32_t crc = strata::crc32c(bytes.data() + begin, end - begin);
    std::memcpy(bytes.data() + at, &crc, 4);
}

// Fixes the payload checksums, then the node table's, inside the table at [table, end); stops where
// the table does not hold what it claims.
void repair_node_table(std::vector<uint8_t>& file, uint64_t table, uint64_t node_count) {
    uint64_t at = table;
    for (int name = 0; name < 2; ++name) {
        if (file.size() - at < 4) return;
        at += 4 + uint64_t(load<uint32_t>(file, at));
        if (at > file.size()) return;
    }
    if (node_count > (file.size() - at) / kNodeBytes) return;
    for (uint64_t n = 0; n < node_count; ++n, at += kNodeBytes) {
        const uint64_t offset = load<uint64_t>(file, at + kNodeOffsetAt);
        const uint64_t size = load<uint64_t>(file, at + kNodeSizeAt);
        if (offset <= file.size() && size <= file.size() - offset)
            store_crc(file, at + kNodeChecksumAt, offset, offset + size);
    }
    if (file.size() - at >= 4) store_crc(file, at, table, at);
}

void repair_checksums(std::vector<uint8_t>& file) {
    if (file.size() < kHeaderBytes) return;
    const uint64_t table = load<uint64_t>(file, kNodeTableOffsetAt);
    if (table >= kHeaderBytes && table <= file.size()) repair_node_table(file, table, load<uint64_t>(file, kNodeCountAt));
    store_crc(file, kHeaderCrcAt, 0, kHeaderCrcAt);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::vector<uint8_t> file(data, data + size);
    repair_checksums(file);
    const std::filesystem::path path = strata::fuzz::scratch_file("fuzz.hlod", file.data(), file.size());
    try {
        strata::HlodFile hlod(path);
        for (const strata::HlodNode& node : hlod.nodes()) hlod.read_cube(node);
        strata::verify_hlod(hlod);
    } catch (const std::runtime_error& error) {
        strata::fuzz::expect_named(error.what(), path.string());
    }
    return 0;
}
