#include "preprocess/triangle_spill.h"

#include <cstring>

namespace strata::build {

size_t spill_triangles(const TriangleBatch& batch, const Frame& f, const CornerLayout& layout, RunSpill& spill) {
    const size_t corner = layout.bytes();
    uint8_t record[3 * CornerLayout::kMostBytes];
    size_t spilled = 0;
    for (size_t t = 0; t < batch.triangle_count(); ++t) {
        if (batch.degenerate(t)) continue;
        const float* p = &batch.positions[9 * t];
        for (size_t c = 0; c < 3; ++c) {
            uint8_t* out = record + c * corner;
            std::memcpy(out, &batch.positions[9 * t + 3 * c], 12);
            if (layout.kept.normals) std::memcpy(out + layout.normal_offset(), &batch.normals[9 * t + 3 * c], 12);
            if (layout.kept.colors) std::memcpy(out + layout.color_offset(), &batch.colors[12 * t + 4 * c], 4);
            if (layout.kept.uvs) std::memcpy(out + layout.uv_offset(), &batch.uvs[6 * t + 2 * c], 8);
        }
        spill.append(f.block_of(cell_of(f, barycenter(p, p + 3, p + 6), f.max_level)), record, 3 * corner);
        ++spilled;
    }
    return spilled;
}

}  // namespace strata::build
