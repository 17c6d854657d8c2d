#include "preprocess/cube_store.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace strata::build {
namespace {

enum RecordFlags : uint8_t { kColors = 1, kUvs = 2, kNormals = 4 };

template <class T>
void append(std::vector<uint8_t>& out, const std::vector<T>& values) {
    const auto* p = reinterpret_cast<const uint8_t*>(values.data());
    out.insert(out.end(), p, p + values.size() * sizeof(T));
}

template <class T>
void take(const uint8_t*& at, std::vector<T>& values, size_t count) {
    values.resize(count);
    if (count) std::memcpy(values.data(), at, count * sizeof(T));  // an empty vector's data() may be null
    at += count * sizeof(T);
}

// The record's bytes: key, error, counts, flags, child counts, then the arrays as they are in memory.
std::vector<uint8_t> serialize(const CubeRecord& c) {
    struct Head {
        CubeKey key;
        float error;
        uint32_t vertices, triangles;
        uint8_t flags, pad[3];
        std::array<uint32_t, 8> child_counts;
    } head{c.key, c.error, c.vertex_count(), c.triangle_count(),
           uint8_t((c.colors.empty() ? 0 : kColors) | (c.uvs.empty() ? 0 : kUvs) | (c.normals.empty() ? 0 : kNormals)),
           {0, 0, 0}, c.child_counts};
    std::vector<uint8_t> out(sizeof(Head));
    std::memcpy(out.data(), &head, sizeof(Head));
    append(out, c.positions), append(out, c.colors), append(out, c.uvs), append(out, c.normals), append(out, c.triangles);
    return out;
}

CubeRecord deserialize(const std::vector<uint8_t>& bytes) {
    CubeRecord c;
    const uint8_t* at = bytes.data();
    uint32_t vertices, triangles;
    uint8_t flags;
    std::memcpy(&c.key, at, 8), std::memcpy(&c.error, at + 8, 4), std::memcpy(&vertices, at + 12, 4);
    std::memcpy(&triangles, at + 16, 4), std::memcpy(&flags, at + 20, 1), std::memcpy(c.child_counts.data(), at + 24, 32);
    at += 56;
    take(at, c.positions, 3 * size_t(vertices));
    take(at, c.colors, flags & kColors ? 4 * size_t(vertices) : 0);
    take(at, c.uvs, flags & kUvs ? 2 * size_t(vertices) : 0);
    take(at, c.normals, flags & kNormals ? 3 * size_t(vertices) : 0);
    take(at, c.triangles, 3 * size_t(triangles));
    return c;
}

}  // namespace

CubeStore::CubeStore(std::filesystem::path path, DiskUsage& usage) : file_(std::move(path), usage) {}

void CubeStore::put(const CubeRecord& cube) {
    const std::vector<uint8_t> bytes = serialize(cube);
    const uint64_t offset = end_.fetch_add(bytes.size());
    triangles_ += cube.triangle_count();
    file_.write(bytes.data(), bytes.size(), offset);
    std::lock_guard lock(mutex_);
    index_.push_back(Entry{cube.key, offset, uint32_t(bytes.size())});
    sorted_ = false;
}

const std::vector<CubeKey>& CubeStore::keys() {
    if (!sorted_) {
        std::sort(index_.begin(), index_.end(), [](const Entry& a, const Entry& b) { return a.key < b.key; });
        keys_.clear();
        for (const Entry& e : index_) keys_.push_back(e.key);
        sorted_ = true;
    }
    return keys_;
}

CubeRecord CubeStore::get(CubeKey key) const {
    const auto it = std::lower_bound(index_.begin(), index_.end(), key, [](const Entry& e, CubeKey k) { return e.key < k; });
    if (!sorted_ || it == index_.end() || it->key != key) throw std::logic_error("CubeStore::get: no such cube");
    std::vector<uint8_t> bytes(it->size);
    file_.read(bytes.data(), bytes.size(), it->offset);
    return deserialize(bytes);
}

}  // namespace strata::build
