// Fuzz target: the .hlod reader (preprocess/hlod_format.cpp) as `strata verify` and the viewer use it:
// open the file (header, section table, MODL, NODE, GEOR, TERR), decode every cube's payload, then check the
// model as `strata verify` does (a terrain's heights, HGHT, textures, TXTR, and an embedding's section, EMBD, included). Properties: every failure is a std::runtime_error naming the file;
// nothing crashes or allocates without bound.
//
// The input is a .hlod file. A mutated byte would almost always break a CRC-32C (or the file size the
// header declares) and stop the reader at the first check, so before the file is written those are
// recomputed wherever its structure lets them be found (payload CRCs in NODE, block CRCs in HGHT's index
// and texture CRCs in TXTR's, and those indexes' own, each section's CRC, the declared size, the header CRC; FORMAT.md §3–4). The reader itself is unchanged, and the same inputs
// replay the same way in the ordinary build.
#include <cstring>
#include <stdexcept>
#include <vector>

#include "preprocess/hlod_format.h"
#include "preprocess/hlod_verify.h"
#include "tests/fuzz/fuzz_support.h"
#include "tests/support/hlod_bytes.h"

namespace {

using namespace strata::test;

bool inside(const std::vector<uint8_t>& file, uint64_t offset, uint64_t size) {
    return offset <= file.size() && size <= file.size() - offset;
}

// Fixes the payload checksums of the node entries in [offset, offset + size).
void repair_node_entries(std::vector<uint8_t>& file, uint64_t offset, uint64_t size) {
    for (uint64_t at = offset; at + kNodeBytes <= offset + size; at += kNodeBytes) {
        const uint64_t payload = get<uint64_t>(file, at + kNodeOffsetAt), bytes = get<uint64_t>(file, at + kNodeSizeAt);
        if (inside(file, payload, bytes)) put(file, at + kNodeChecksumAt, strata::crc32c(file.data() + payload, bytes));
    }
}

// Fixes a section indexed by 16-byte entries (u64 offset from the section, u32 size, u32 CRC) after a
// head of `kHead` bytes holding their count and the index's CRC: a terrain's heights (FORMAT.md §4.8,
// its blocks) and a model's textures (§4.9, one a cube). Each entry's CRC, then the index's.
template <uint64_t kHead, uint64_t kCountAt, uint64_t kIndexCrcAt>
void repair_index(std::vector<uint8_t>& file, uint64_t offset, uint64_t size) {
    constexpr uint64_t kEntry = 16;
    if (size < kHead) return;
    const uint64_t count = get<uint64_t>(file, offset + kCountAt);
    if (count > (size - kHead) / kEntry) return;
    for (uint64_t e = 0; e < count; ++e) {
        const uint64_t entry = offset + kHead + kEntry * e;
        const uint64_t block = get<uint64_t>(file, entry), bytes = get<uint32_t>(file, entry + 8);
        if (block <= size && bytes <= size - block) put(file, entry + 12, strata::crc32c(file.data() + offset + block, bytes));
    }
    put(file, offset + kIndexCrcAt, strata::crc32c(file.data() + offset + kHead, kEntry * count));
}

void repair_checksums(std::vector<uint8_t>& file) {
    if (file.size() < kFixedHeaderBytes) return;
    const uint64_t count = get<uint32_t>(file, kSectionCountAt);
    if (count > (file.size() - kFixedHeaderBytes) / kEntryBytes) return;
    put<uint64_t>(file, kFileSizeAt, file.size());
    // NODE first: the payload CRCs it holds are part of its own CRC.
    for (int pass = 0; pass < 2; ++pass)
        for (uint64_t e = 0; e < count; ++e) {
            const size_t entry = kFixedHeaderBytes + kEntryBytes * e;
            const uint64_t offset = get<uint64_t>(file, entry + kEntryOffsetAt), size = get<uint64_t>(file, entry + kEntrySizeAt);
            if (!inside(file, offset, size)) continue;
            if (pass == 0 && std::memcmp(&file[entry], "NODE", 4) == 0) repair_node_entries(file, offset, size);
            if (pass == 0 && std::memcmp(&file[entry], "HGHT", 4) == 0) repair_index<56, 40, 48>(file, offset, size);
            if (pass == 0 && std::memcmp(&file[entry], "TXTR", 4) == 0) repair_index<32, 16, 24>(file, offset, size);
            if (pass == 1) put(file, entry + kEntryCrcAt, strata::crc32c(file.data() + offset, size));
        }
    std::vector<uint8_t> covered(file.begin(), file.begin() + kHeaderCrcAt);
    covered.insert(covered.end(), file.begin() + kFixedHeaderBytes, file.begin() + long(kFixedHeaderBytes + kEntryBytes * count));
    put(file, kHeaderCrcAt, strata::crc32c(covered.data(), covered.size()));
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
