// An open-addressing hash map from 32-bit ids to 32-bit ids, for the hot loops that renumber vertices
// (global → block-local, global → cube-local). Flat arrays, linear probing, no erase; it doubles when
// half full, and reset() reuses the storage, so a worker keeps one map for all its blocks.
#pragma once

#include <cstdint>
#include <algorithm>
#include <stdexcept>
#include <vector>

namespace strata {

class IndexMap {
public:
    static constexpr uint32_t kMissing = ~0u;

    explicit IndexMap(size_t expected) { reset(expected); }

    // Empties the map and sizes it for about `expected` entries.
    void reset(size_t expected) {
        size_t capacity = 16;
        while (capacity < 2 * expected) capacity *= 2;
        if (capacity != keys_.size()) {
            keys_.assign(capacity, kMissing);
            values_.resize(capacity);
        } else {
            std::fill(keys_.begin(), keys_.end(), kMissing);
        }
        mask_ = capacity - 1;
        size_ = 0;
    }

    // The value stored for key, or kMissing.
    uint32_t find(uint32_t key) const {
        for (size_t slot = hash(key) & mask_;; slot = (slot + 1) & mask_) {
            if (keys_[slot] == key) return values_[slot];
            if (keys_[slot] == kMissing) return kMissing;
        }
    }

    // The value stored for key; if there is none, stores `value` and returns it.
    uint32_t find_or_insert(uint32_t key, uint32_t value) {
        for (size_t slot = hash(key) & mask_;; slot = (slot + 1) & mask_) {
            if (keys_[slot] == key) return values_[slot];
            if (keys_[slot] == kMissing) {
                keys_[slot] = key;
                values_[slot] = value;
                if (2 * ++size_ > keys_.size()) grow();
                return value;
            }
        }
    }

    // Set-of-items mode: the item equal to `item` (by `same(stored)`) under the caller's hash, or
    // `item` itself once inserted. Items are ids; equality is whatever they stand for.
    template <class Same>
    uint32_t find_or_insert(uint64_t item_hash, uint32_t item, Same&& same) {
        for (size_t slot = mix(item_hash) & mask_;; slot = (slot + 1) & mask_) {
            if (keys_[slot] == kMissing) {
                keys_[slot] = item;
                if (2 * ++size_ > keys_.size()) throw std::logic_error("IndexMap: set-of-items mode needs its full size up front");
                return item;
            }
            if (same(keys_[slot])) return keys_[slot];
        }
    }

    // Set-of-items mode, lookup only: the stored item that `same` accepts, or kMissing.
    template <class Same>
    uint32_t find(uint64_t item_hash, Same&& same) const {
        for (size_t slot = mix(item_hash) & mask_;; slot = (slot + 1) & mask_) {
            if (keys_[slot] == kMissing) return kMissing;
            if (same(keys_[slot])) return keys_[slot];
        }
    }

    size_t memory_bytes() const { return (keys_.capacity() + values_.capacity()) * sizeof(uint32_t); }

private:
    void grow() {
        std::vector<uint32_t> keys(keys_.size() * 2, kMissing), values(keys_.size() * 2);
        const size_t mask = keys.size() - 1;
        for (size_t i = 0; i < keys_.size(); ++i) {
            if (keys_[i] == kMissing) continue;
            size_t slot = hash(keys_[i]) & mask;
            while (keys[slot] != kMissing) slot = (slot + 1) & mask;
            keys[slot] = keys_[i], values[slot] = values_[i];
        }
        keys_.swap(keys), values_.swap(values);
        mask_ = mask;
    }

    static uint64_t mix(uint64_t h) {
        h ^= h >> 33;
        h *= 0xff51afd7ed558ccdull;
        h ^= h >> 33;
        return h;
    }
    static uint64_t hash(uint32_t key) { return mix(key); }

    std::vector<uint32_t> keys_, values_;
    size_t mask_ = 0;
    size_t size_ = 0;
};

// Numbers `count` items by equality: class_of[i] is the rank, among the first items of their kind, of
// the first item equal to i. Returns those first items in order. hash(i) must agree for equal items.
template <class Hash, class Same>
std::vector<uint32_t> number_distinct(uint32_t count, Hash&& hash, Same&& same, std::vector<uint32_t>& class_of) {
    class_of.resize(count);
    IndexMap first(count);
    std::vector<uint32_t> firsts, class_of_first(count);
    for (uint32_t i = 0; i < count; ++i) {
        const uint32_t found = first.find_or_insert(hash(i), i, [&](uint32_t other) { return same(other, i); });
        if (found == i) {
            class_of_first[i] = uint32_t(firsts.size());
            firsts.push_back(i);
        }
        class_of[i] = class_of_first[found];
    }
    return firsts;
}

}  // namespace strata
