// GPU resources of drawables (buffers of a model, its draw commands), owned by the renderer: they
// must be deleted while its GL context lives, which a node held by a script may outlive.
#pragma once

#include <cstdint>
#include <memory>
#include <unordered_map>

namespace strata {

class GpuCache {
public:
    struct Entry {
        virtual ~Entry() = default;
    };

    // The entry of node `id`, made by `make()` on first use; marked as used this frame.
    template <class T, class Make>
    T& get(uint32_t id, Make&& make) {
        Slot& slot = slots_[id];
        if (!slot.entry) slot.entry = make();
        slot.last_used = frame_;
        return static_cast<T&>(*slot.entry);
    }
    // Ends a frame: drops the entries no frame has used for `keep_frames` frames (their nodes are
    // gone, or hidden for long; a hidden node uploads again when it reappears).
    void end_frame(uint64_t keep_frames = 300) {
        ++frame_;
        std::erase_if(slots_, [&](const auto& kv) { return frame_ - kv.second.last_used > keep_frames; });
    }
    size_t size() const { return slots_.size(); }

private:
    struct Slot {
        std::unique_ptr<Entry> entry;
        uint64_t last_used = 0;
    };
    std::unordered_map<uint32_t, Slot> slots_;
    uint64_t frame_ = 0;
};

}  // namespace strata
