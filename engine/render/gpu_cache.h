// GPU resources of drawables (buffers of a model, its draw commands) and the programs they share,
// owned by the renderer: they must be deleted while its GL context lives, which a node held by a
// script may outlive. A node's entry goes when the node is destroyed (checked each frame) or when no
// frame has used it for a while (a hidden node uploads again when it reappears); so does the entry of
// data several nodes draw from (the cubes of a file two models stream), with the object that owns it.
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
    // The entry of the data `owner` holds, which several nodes may draw (HlodModel::cube_owner),
    // made by `make()` on first use; marked as used this frame.
    template <class T, class Make>
    T& get_owned(const std::shared_ptr<const void>& owner, Make&& make) {
        Slot& slot = owned_[owner.get()];
        // A slot left by an owner since destroyed at the same address is not this owner's.
        if (!slot.entry || slot.alive.owner_before(owner) || owner.owner_before(slot.alive)) {
            slot.entry = make();
            slot.alive = owner;
        }
        slot.last_used = frame_;
        return static_cast<T&>(*slot.entry);
    }
    // A resource many nodes share (a program, the scene's buffer pool), under a key of the caller's
    // choosing; kept for good.
    template <class T, class Make>
    T& get_shared(uint32_t key, Make&& make) {
        std::unique_ptr<Entry>& entry = shared_[key];
        if (!entry) entry = make();
        return static_cast<T&>(*entry);
    }
    // Ends a frame: drops the entries of destroyed nodes, and of nodes unused for `keep_frames` frames.
    void end_frame(uint64_t keep_frames = 300) {
        ++frame_;
        auto stale = [&](const auto& kv) { return kv.second.alive.expired() || frame_ - kv.second.last_used > keep_frames; };
        std::erase_if(nodes_, stale);  // nodes first: their entries may use what their owners' hold
        std::erase_if(owned_, stale);
    }
    size_t size() const { return nodes_.size() + owned_.size(); }
    uint64_t frame() const { return frame_; }  // counts end_frame() calls

private:
    struct Slot {
        std::unique_ptr<Entry> entry;
        std::weak_ptr<const void> alive;
        uint64_t last_used = 0;
    };
    // Declared so that entries go before what they may hold on to: shared ones last.
    std::unordered_map<uint32_t, std::unique_ptr<Entry>> shared_;
    std::unordered_map<const void*, Slot> owned_;
    std::unordered_map<uint32_t, Slot> nodes_;
    uint64_t frame_ = 0;
};

}  // namespace strata
