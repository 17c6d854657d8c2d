// GPU resources of drawables (buffers of a model, its draw commands) and the programs they share,
// owned by the renderer: they must be deleted while its GL context lives, which a node held by a
// script may outlive. A node's entry goes when the node is destroyed (checked each frame) or when no
// frame has used it for a while (a hidden node uploads again when it reappears).
#pragma once

#include <cstdint>
#include <memory>
#include <unordered_map>

#include "engine/scene/node.h"

namespace strata {

class GpuCache {
public:
    struct Entry {
        virtual ~Entry() = default;
    };

    // The entry of `node`, made by `make()` on first use; marked as used this frame.
    template <class T, class Make>
    T& get(const Node& node, Make&& make) {
        Slot& slot = nodes_[node.id()];
        if (!slot.entry) {
            slot.entry = make();
            slot.alive = node.lifetime();
        }
        slot.last_used = frame_;
        return static_cast<T&>(*slot.entry);
    }
    // A resource many nodes share (a program), under a key of the caller's choosing; kept for good.
    template <class T, class Make>
    T& get_shared(uint32_t key, Make&& make) {
        std::unique_ptr<Entry>& entry = shared_[key];
        if (!entry) entry = make();
        return static_cast<T&>(*entry);
    }
    // Ends a frame: drops the entries of destroyed nodes, and of nodes unused for `keep_frames` frames.
    void end_frame(uint64_t keep_frames = 300) {
        ++frame_;
        std::erase_if(nodes_, [&](const auto& kv) {
            return kv.second.alive.expired() || frame_ - kv.second.last_used > keep_frames;
        });
    }
    size_t size() const { return nodes_.size(); }

private:
    struct Slot {
        std::unique_ptr<Entry> entry;
        std::weak_ptr<const void> alive;
        uint64_t last_used = 0;
    };
    std::unordered_map<uint32_t, Slot> nodes_;
    std::unordered_map<uint32_t, std::unique_ptr<Entry>> shared_;
    uint64_t frame_ = 0;
};

}  // namespace strata
