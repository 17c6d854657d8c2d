// Storage buffers shared by many blocks that come and go one at a time (a streamed model's cubes):
// pages, each one dynamic buffer that a shader binds whole, holding blocks placed best-fit inside, so
// that a cube's arrival or eviction uploads or frees that cube alone instead of rebuilding the buffers.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "engine/gl/buffer.h"

namespace strata::gl {

// Best-fit ranges of [0, capacity), in units; a freed range merges with free neighbours. No GL.
class RangeAllocator {
public:
    explicit RangeAllocator(uint64_t capacity);
    // The offset of `size` (≥ 1) free units, the smallest free range that holds them; none when no
    // free range is that large.
    std::optional<uint64_t> allocate(uint64_t size);
    // Returns an allocated range. Throws std::logic_error when any of it is already free or outside.
    void free(uint64_t offset, uint64_t size);

    uint64_t capacity() const { return capacity_; }
    uint64_t used() const { return used_; }
    uint64_t largest_free() const { return by_size_.empty() ? 0 : by_size_.rbegin()->first; }
    size_t free_ranges() const { return free_.size(); }

private:
    void insert_free(uint64_t offset, uint64_t size);
    void erase_free(std::map<uint64_t, uint64_t>::iterator range);

    uint64_t capacity_, used_ = 0;
    std::map<uint64_t, uint64_t> free_;             // offset → size
    std::set<std::pair<uint64_t, uint64_t>> by_size_;  // (size, offset), for best fit
};

class BufferPool {
public:
    static constexpr uint64_t kUnitBytes = 16;  // blocks are placed and sized in 16-byte units
    struct Block {
        uint32_t page = ~0u;
        uint64_t offset = 0;  // units into the page
        uint64_t units = 0;
        explicit operator bool() const { return page != ~0u; }
    };
    static constexpr uint32_t kNoPage = ~0u;

    // Pages of up to `page_bytes` (rounded up to whole units, at most what one storage-buffer binding
    // may hold: GL_MAX_SHADER_STORAGE_BLOCK_SIZE): each new page as large as the pool already is, from
    // kFirstPageBytes on; a block larger than a page gets a page of its own size. Needs a current GL
    // context.
    explicit BufferPool(uint64_t page_bytes);
    static constexpr uint64_t kFirstPageBytes = uint64_t(1) << 20;
    // For pages made from now on.
    void set_page_bytes(uint64_t page_bytes);

    // Places `units` (≥ 1) units, never on the retiring page; throws GlError when one binding cannot
    // hold that many.
    Block allocate(uint64_t units);
    // Frees a block (and its page once empty); the block becomes empty. An empty block is ignored.
    void free(Block& block);
    // Evictions leave pages partly empty, and a page goes back only once empty, so the pages could come
    // to hold far more than their blocks. Once they hold more than two pages' worth of free room, the
    // page with the most of it retires: nothing more is placed there, and the blocks' owners place them
    // again elsewhere (from the data they keep) until it is empty and freed. kNoPage: none retiring.
    uint32_t retiring_page() const { return retiring_; }
    // Writes bytes at `offset_units` into the block. Throws GlError when they do not fit in it.
    void upload(const Block& block, uint64_t offset_units, const void* data, uint64_t size_bytes);

    // By index as blocks name them; a page freed since is an empty Buffer.
    uint32_t page_count() const { return uint32_t(pages_.size()); }
    const Buffer& page(uint32_t index) const { return pages_[index].buffer; }
    uint64_t capacity_bytes() const;  // of every page held: what the pool takes on the GPU
    uint64_t used_bytes() const;      // of the blocks placed
    uint64_t page_units() const { return page_units_; }

private:
    // Chooses the page to retire when none is and the pages' free room has passed the limit.
    void choose_retiring_page();

    struct Page {
        Buffer buffer;  // empty once freed
        RangeAllocator ranges{0};
    };
    uint64_t page_units_, max_units_;
    std::vector<Page> pages_;
    uint32_t retiring_ = kNoPage;
};

}  // namespace strata::gl
