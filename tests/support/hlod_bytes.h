// Where the .hlod container keeps what tests and fuzzing edit by hand (FORMAT.md §3–4), and how to
// read and write a little-endian value at a byte offset. One copy, so the tests and the fuzz target
// cannot drift apart when the layout changes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace strata::test {

// §3: the fixed header and the section table that follows it.
inline constexpr size_t kFixedHeaderBytes = 32, kSectionCountAt = 12, kFileSizeAt = 16, kHeaderCrcAt = 28;
inline constexpr size_t kTableAt = kFixedHeaderBytes, kEntryBytes = 32, kEntryOffsetAt = 8, kEntrySizeAt = 16,
                        kEntryCrcAt = 24;
// §4.2: a NODE entry.
inline constexpr size_t kNodeBytes = 48, kNodeOffsetAt = 0, kNodeSizeAt = 8, kNodeLevelAt = 16, kNodeVerticesAt = 36,
                        kNodeChecksumAt = 44;

template <class T>
T get(const std::vector<uint8_t>& bytes, size_t at) {
    T value;
    std::memcpy(&value, bytes.data() + at, sizeof(T));
    return value;
}

template <class T>
void put(std::vector<uint8_t>& bytes, size_t at, T value) {
    std::memcpy(bytes.data() + at, &value, sizeof(T));
}

}  // namespace strata::test
