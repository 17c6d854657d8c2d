// Stable LSD radix sort of ids by unsigned integer keys, 11 bits per pass over only the bits in use.
// Used where std::sort showed up in profiles: collapse candidates by cost (a non-negative float's
// bits order like the float) and triangles by cube. Stable, so ties keep id order: deterministic.
#pragma once

#include <cstdint>
#include <vector>

namespace strata {

// Reorders `ids` so that keys[ids[i]] ascends; keys are indexed by id. `bits`: how many low bits of
// the keys can be nonzero.
template <class Key>
void radix_sort_ids(const std::vector<Key>& keys, std::vector<uint32_t>& ids, int bits) {
    constexpr int kDigitBits = 11;
    constexpr size_t kBuckets = size_t(1) << kDigitBits;
    std::vector<uint32_t> scratch(ids.size());
    size_t counts[kBuckets];
    for (int shift = 0; shift < bits; shift += kDigitBits) {
        std::fill(counts, counts + kBuckets, 0);
        for (uint32_t id : ids) ++counts[(keys[id] >> shift) & (kBuckets - 1)];
        size_t sum = 0;
        for (size_t& c : counts) {
            size_t n = c;
            c = sum;
            sum += n;
        }
        for (uint32_t id : ids) scratch[counts[(keys[id] >> shift) & (kBuckets - 1)]++] = id;
        ids.swap(scratch);
    }
}

}  // namespace strata
