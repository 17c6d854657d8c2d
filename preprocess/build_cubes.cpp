#include "preprocess/build_cubes.h"

#include <meshoptimizer.h>

namespace strata::build {

void order_for_payload(std::vector<uint32_t>& indices, const std::array<uint32_t, 8>& child_counts,
                       std::vector<uint32_t>& vertices) {
    size_t first = 0;
    for (uint32_t count : child_counts) {
        if (count) meshopt_optimizeVertexCacheFifo(&indices[first], &indices[first], 3 * size_t(count), vertices.size(), 16);
        first += 3 * size_t(count);
    }
    std::vector<uint32_t> fetch(vertices.size());
    const size_t used = meshopt_optimizeVertexFetchRemap(fetch.data(), indices.data(), indices.size(), vertices.size());
    std::vector<uint32_t> ordered(used);
    for (size_t v = 0; v < vertices.size(); ++v)
        if (fetch[v] != ~0u) ordered[fetch[v]] = vertices[v];
    for (uint32_t& i : indices) i = fetch[i];
    vertices.swap(ordered);
}

}  // namespace strata::build
