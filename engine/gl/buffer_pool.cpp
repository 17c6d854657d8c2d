// RangeAllocator and BufferPool: best-fit placement in pages of dynamic storage buffers.
#include "engine/gl/buffer_pool.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace strata::gl {

RangeAllocator::RangeAllocator(uint64_t capacity) : capacity_(capacity) {
    if (capacity > 0) insert_free(0, capacity);
}

void RangeAllocator::insert_free(uint64_t offset, uint64_t size) {
    free_.emplace(offset, size);
    by_size_.emplace(size, offset);
}

void RangeAllocator::erase_free(std::map<uint64_t, uint64_t>::iterator range) {
    by_size_.erase({range->second, range->first});
    free_.erase(range);
}

std::optional<uint64_t> RangeAllocator::allocate(uint64_t size) {
    if (size == 0) throw std::logic_error("RangeAllocator: a range of 0 units");
    const auto fit = by_size_.lower_bound({size, 0});
    if (fit == by_size_.end()) return std::nullopt;
    const auto [free_size, offset] = *fit;
    erase_free(free_.find(offset));
    if (free_size > size) insert_free(offset + size, free_size - size);
    used_ += size;
    return offset;
}

void RangeAllocator::free(uint64_t offset, uint64_t size) {
    const auto describe = [&] {
        return "[" + std::to_string(offset) + ", " + std::to_string(offset + size) + ")";
    };
    if (size == 0 || offset > capacity_ || size > capacity_ - offset)
        throw std::logic_error("RangeAllocator: freeing " + describe() + ", outside the " + std::to_string(capacity_) + " units");
    auto next = free_.lower_bound(offset);
    if (next != free_.end() && next->first < offset + size)
        throw std::logic_error("RangeAllocator: freeing " + describe() + ", which is partly free already");
    uint64_t start = offset, end = offset + size;
    if (next != free_.begin()) {
        const auto previous = std::prev(next);
        if (previous->first + previous->second > offset)
            throw std::logic_error("RangeAllocator: freeing " + describe() + ", which is partly free already");
        if (previous->first + previous->second == offset) {
            start = previous->first;
            erase_free(previous);
        }
    }
    if (next != free_.end() && next->first == end) {
        end += next->second;
        erase_free(next);
    }
    insert_free(start, end - start);
    used_ -= size;
}

namespace {

uint64_t max_binding_units() { return max_storage_block_bytes() / BufferPool::kUnitBytes; }

}  // namespace

BufferPool::BufferPool(uint64_t page_bytes) : max_units_(max_binding_units()) { set_page_bytes(page_bytes); }

void BufferPool::set_page_bytes(uint64_t page_bytes) {
    page_units_ = std::min(std::max<uint64_t>(1, (page_bytes + kUnitBytes - 1) / kUnitBytes), max_units_);
}

BufferPool::Block BufferPool::allocate(uint64_t units) {
    if (units == 0 || units > max_units_)
        throw GlError("BufferPool: a block of " + std::to_string(units * kUnitBytes) + " bytes; one storage buffer binding holds at most " +
                      std::to_string(max_units_ * kUnitBytes));
    for (uint32_t p = 0; p < pages_.size(); ++p) {
        if (!pages_[p].buffer.id() || p == retiring_) continue;
        if (const auto offset = pages_[p].ranges.allocate(units)) return {p, *offset, units};
    }
    // A new page, in the first slot a freed page left: as large as the pool already is, from
    // kFirstPageBytes up to the page size, so that a small scene takes little more than it holds.
    const uint64_t grown = std::max(kFirstPageBytes / kUnitBytes, capacity_bytes() / kUnitBytes);
    const uint64_t capacity = std::max(units, std::min(grown, page_units_));
    uint32_t p = 0;
    while (p < pages_.size() && pages_[p].buffer.id()) ++p;
    if (p == pages_.size()) pages_.emplace_back();
    pages_[p] = Page{Buffer(capacity * kUnitBytes, kDynamicStorage), RangeAllocator(capacity)};
    return {p, *pages_[p].ranges.allocate(units), units};
}

void BufferPool::choose_retiring_page() {
    if (retiring_ != kNoPage) return;
    uint64_t free_units = 0, most_free = 0;
    uint32_t emptiest = kNoPage;
    for (uint32_t p = 0; p < pages_.size(); ++p) {
        if (!pages_[p].buffer.id()) continue;
        const RangeAllocator& ranges = pages_[p].ranges;
        free_units += ranges.capacity() - ranges.used();
        if (ranges.capacity() - ranges.used() > most_free) most_free = ranges.capacity() - ranges.used(), emptiest = p;
    }
    if (free_units > 2 * page_units_) retiring_ = emptiest;
}

void BufferPool::free(Block& block) {
    if (!block) return;
    Page& page = pages_.at(block.page);
    page.ranges.free(block.offset, block.units);
    if (page.ranges.used() == 0) {
        page = Page{};
        if (block.page == retiring_) retiring_ = kNoPage;
    }
    block = {};
    choose_retiring_page();
}

void BufferPool::upload(const Block& block, uint64_t offset_units, const void* data, uint64_t size_bytes) {
    if (!block || offset_units > block.units || size_bytes > (block.units - offset_units) * kUnitBytes)
        throw GlError("BufferPool::upload: " + std::to_string(size_bytes) + " bytes at unit " + std::to_string(offset_units) +
                      " do not fit a block of " + std::to_string(block.units) + " units");
    pages_[block.page].buffer.upload((block.offset + offset_units) * kUnitBytes, data, size_bytes);
}

uint64_t BufferPool::capacity_bytes() const {
    uint64_t bytes = 0;
    for (const Page& page : pages_) bytes += page.buffer.size();
    return bytes;
}

uint64_t BufferPool::used_bytes() const {
    uint64_t units = 0;
    for (const Page& page : pages_) units += page.ranges.used();
    return units * kUnitBytes;
}

}  // namespace strata::gl
