#include "engine/scene/cull_visitor.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "engine/scene/drawable.h"
#include "engine/scene/light.h"

namespace strata {

namespace {

// The depth as an unsigned integer in the same order (IEEE 754: negatives get all their bits flipped, the
// rest their sign bit). −0 ties with +0, as the comparison does; a NaN sorts with +∞, last.
uint64_t order_key(double depth) {
    if (std::isnan(depth)) depth = std::numeric_limits<double>::infinity();
    if (depth == 0) depth = 0;
    uint64_t bits;
    std::memcpy(&bits, &depth, sizeof bits);
    return bits >> 63 ? ~bits : bits | (uint64_t(1) << 63);
}

}  // namespace

void RenderList::sort() {
    // Items carry a 4×4 double matrix each, so they are not sorted themselves: their depths are, as
    // integer keys, by a least-significant-digit-first radix sort of 11-bit digits (stable: ties keep the
    // traversal order; a digit every key shares is skipped), and the items are then gathered once.
    const size_t n = opaque.size();
    if (n < 2) return;
    constexpr int kBits = 11, kDigits = (64 + kBits - 1) / kBits;
    constexpr uint64_t kMask = (1u << kBits) - 1;
    struct Key {
        uint64_t key;
        uint32_t index;
    };
    std::vector<Key> keys(n), spare(n);
    std::vector<uint32_t> counts(kDigits << kBits, 0);
    for (size_t i = 0; i < n; ++i) {
        keys[i] = {order_key(opaque[i].depth), uint32_t(i)};
        for (int digit = 0; digit < kDigits; ++digit) ++counts[digit << kBits | (keys[i].key >> (kBits * digit) & kMask)];
    }
    for (int digit = 0; digit < kDigits; ++digit) {
        uint32_t* count = &counts[digit << kBits];
        const int shift = kBits * digit;
        if (count[keys[0].key >> shift & kMask] == n) continue;
        uint32_t offset = 0;
        for (uint64_t d = 0; d <= kMask; ++d) offset += std::exchange(count[d], offset);
        for (const Key& k : keys) spare[count[k.key >> shift & kMask]++] = k;
        keys.swap(spare);
    }
    std::vector<DrawItem> sorted;
    sorted.reserve(opaque.capacity());
    for (const Key& k : keys) sorted.push_back(opaque[k.index]);
    opaque.swap(sorted);
}

CullVisitor::CullVisitor(const Camera& camera, const glm::dmat4& view, const glm::dmat4& projection, RenderList& out)
    : camera_(camera), view_(view), eye_world_(glm::inverse(view)[3]), out_(out) {
    state_.push_back({glm::dmat4(1.0), Frustum::from_matrix(projection * view), kAllPlanes});
}

bool CullVisitor::enter(Node& node, uint8_t& mask) {
    if (!(node.mask() & traversal_mask_)) return false;
    ++stats_.nodes_visited;
    mask = state_.back().mask;
    if (!culling_ || mask == 0) return true;
    ++stats_.bound_tests;
    if (intersects(state_.back().frustum, node.bound(), mask)) return true;
    ++stats_.nodes_culled;
    return false;
}

void CullVisitor::apply(Node& node) {
    uint8_t mask;
    if (enter(node, mask)) traverse(node);
}

void CullVisitor::apply(Group& group) {
    uint8_t mask;
    if (!enter(group, mask)) return;
    const uint8_t saved = state_.back().mask;
    state_.back().mask = mask;
    traverse(group, [this, saved] { state_.back().mask = saved; });
}

void CullVisitor::apply(Transform& transform) {
    uint8_t mask;
    if (!enter(transform, mask)) return;
    const Frame& parent = state_.back();
    state_.push_back({parent.model * transform.matrix(), parent.frustum.in_child_frame(transform.matrix()), mask});
    traverse(transform, [this] { state_.pop_back(); });
}

void CullVisitor::apply(Drawable& drawable) {
    uint8_t mask;
    if (!enter(drawable, mask)) return;
    const uint8_t saved = state_.back().mask;
    state_.back().mask = mask;
    drawable.cull(*this);
    state_.back().mask = saved;
}

// Cameras in the graph are poses to look through, not things to draw.
void CullVisitor::apply(Camera&) {}

void CullVisitor::apply(DirectionalLight& light) {
    if (!(light.mask() & traversal_mask_)) return;
    const glm::dvec3 direction = glm::dmat3(model()) * light.direction;
    const double length = glm::length(direction);
    if (length == 0) return;
    out_.lights.push_back({direction / length, light.color * light.intensity});
}

void CullVisitor::apply(AmbientLight& light) {
    if (!(light.mask() & traversal_mask_)) return;
    out_.ambient += light.color;
    out_.has_ambient = true;
}

glm::dvec3 CullVisitor::local_eye() const { return glm::dvec3(glm::inverse(model()) * glm::dvec4(eye_world_, 1.0)); }

void CullVisitor::add(Drawable& drawable, const uint32_t* data, uint32_t count, std::shared_ptr<const void> state) {
    const uint32_t first = uint32_t(out_.item_data.size());
    out_.item_data.insert(out_.item_data.end(), data, data + count);
    const glm::dvec3 center = glm::dvec3(model() * glm::dvec4(drawable.bound().center(), 1.0));
    const double depth = -(view_ * glm::dvec4(center, 1.0)).z;
    out_.opaque.push_back({&drawable, model(), depth, first, count, std::move(state)});
}

}  // namespace strata
