#include "preprocess/imagery_sampler.h"

#include <algorithm>
#include <cmath>

namespace strata {
namespace {

constexpr uint8_t kNoImage = 128;  // where the level has no cube: the mid grey a terrain's texture shows off its image

// A column of cubes (every k of one level's cell i, j): their textures are the same ground's, seen
// from above (the mapping ignores z).
uint64_t column_key(uint32_t level, uint64_t i, uint64_t j) { return uint64_t(level) << 60 | j << 30 | i; }

}  // namespace

ImagerySampler::ImagerySampler(const HlodHeader& header, const CubeTextures& textures, uint64_t node_count,
                               const std::function<const HlodNode&(uint64_t)>& node, const double lo[2], const double hi[2])
    : header_(header), textures_(textures) {
    const double margin = textures.layout().margin;
    for (uint64_t n = 0; n < node_count; ++n) {
        const HlodNode& c = node(n);
        const double s = header.cube_size(c.level);
        const double x = header.origin[0] + double(c.i) * s, y = header.origin[1] + double(c.j) * s;
        if (x + (1 + margin) * s < lo[0] || x - margin * s > hi[0] || y + (1 + margin) * s < lo[1] || y - margin * s > hi[1]) continue;
        cubes_.try_emplace(column_key(c.level, c.i, c.j), Cube{n, c});
    }
}

double ImagerySampler::texel_spacing(uint32_t level) const {
    const TextureLayout& layout = textures_.layout();
    return (1 + 2 * double(layout.margin)) * header_.cube_size(level) / layout.size;
}

uint32_t ImagerySampler::level_for(double spacing) const {
    for (uint32_t level = 0; level < header_.max_level; ++level)
        if (texel_spacing(level) <= spacing) return level;
    return header_.max_level;
}

const std::vector<uint8_t>& ImagerySampler::decoded(const Cube& cube) {
    if (const auto it = kept_.find(cube.index); it != kept_.end()) return it->second;
    if (auto it = previous_.find(cube.index); it != previous_.end()) return kept_[cube.index] = std::move(it->second);
    const uint32_t size = textures_.layout().size;
    const std::vector<uint8_t> chain = textures_.read(cube.index, cube.node);
    return kept_[cube.index] = decode_bc1(std::span(chain).first(TextureLayout::bc1_bytes(size)), size);
}

std::vector<uint8_t> ImagerySampler::sample(uint32_t level, const TexelGrid& grid) {
    previous_ = std::move(kept_);
    kept_.clear();
    const std::array<float, 256>& linear = srgb_to_linear_table();
    const int size = int(textures_.layout().size);
    const double s = header_.cube_size(level), margin = textures_.layout().margin;
    const double texels_per_cell = size / (1 + 2 * margin);
    std::vector<uint8_t> out(size_t(grid.columns) * grid.rows * 3, kNoImage);
    uint64_t last_key = ~uint64_t(0);
    const std::vector<uint8_t>* rgb = nullptr;
    for (uint32_t r = 0; r < grid.rows; ++r)
        for (uint32_t c = 0; c < grid.columns; ++c) {
            // In cells of the level from the model's origin: the cell that holds the texel, and where in its texture.
            const double u = (grid.x0 + c * grid.step - header_.origin[0]) / s, v = (grid.y0 + r * grid.step - header_.origin[1]) / s;
            const double i = std::floor(u), j = std::floor(v);
            if (i < 0 || j < 0) continue;
            const uint64_t key = column_key(level, uint64_t(i), uint64_t(j));
            if (key != last_key) {
                const auto it = cubes_.find(key);
                rgb = it == cubes_.end() ? nullptr : &decoded(it->second);
                last_key = key;
            }
            if (!rgb) continue;
            const double tx = (u - i + margin) * texels_per_cell - 0.5, ty = (v - j + margin) * texels_per_cell - 0.5;
            const int x0 = int(std::floor(tx)), y0 = int(std::floor(ty));
            const float fx = float(tx - x0), fy = float(ty - y0);
            auto at = [&](int x, int y, int channel) {
                x = std::clamp(x, 0, size - 1), y = std::clamp(y, 0, size - 1);
                return linear[(*rgb)[(size_t(y) * size_t(size) + size_t(x)) * 3 + size_t(channel)]];
            };
            for (int channel = 0; channel < 3; ++channel) {
                const float below = at(x0, y0, channel) * (1 - fx) + at(x0 + 1, y0, channel) * fx;
                const float above = at(x0, y0 + 1, channel) * (1 - fx) + at(x0 + 1, y0 + 1, channel) * fx;
                out[(size_t(r) * grid.columns + c) * 3 + size_t(channel)] = linear_to_srgb(below * (1 - fy) + above * fy);
            }
        }
    previous_.clear();
    return out;
}

}  // namespace strata
