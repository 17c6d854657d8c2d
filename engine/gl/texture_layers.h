// Square BC1 (DXT1) sRGB textures of one size, each a layer of a 2D array texture (a page), so that
// the cubes of a multi-draw sample their own textures from one binding: the shader reads a cube's
// layer from a table. Layers are taken lowest page first and given back one at a time; a page holds
// up to the driver's layer limit. What the BufferPool is for the cubes' vertices, this is for their
// textures.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "engine/gl/gl.h"
#include "engine/gl/object_name.h"

namespace strata::gl {

class TextureLayers {
public:
    struct Layer {
        uint32_t page = ~0u, layer = 0;
        explicit operator bool() const { return page != ~0u; }
    };

    // Whether the context samples BC1 as sRGB (GL_EXT_texture_compression_s3tc with GL_EXT_texture_sRGB,
    // or the s3tc_srgb extension): every desktop driver, and Mesa's software rasterisers.
    static bool supported();
    // Layers of size × size texels with the mips down to 4 × 4; pages of about `page_bytes` (at least
    // one layer, at most the driver's layer limit). Throws std::runtime_error when BC1 is not supported.
    TextureLayers(uint32_t size, uint64_t page_bytes);

    Layer allocate();
    void free(Layer& layer);  // and sets it to none; none is ignored
    // The layer's BC1 mip chain, mip 0 first (preprocess/cube_textures.h's layout).
    void upload(Layer layer, std::span<const uint8_t> chain);

    GLuint page(uint32_t page) const { return pages_[page].name.get(); }
    uint32_t layers_per_page() const { return layers_per_page_; }
    uint64_t layer_bytes() const { return layer_bytes_; }
    uint64_t capacity_bytes() const { return uint64_t(pages_.size()) * layers_per_page_ * layer_bytes_; }

private:
    struct Page {
        ObjectName<DeleteTexture> name;
        std::vector<uint32_t> free;  // layers not taken, highest first (taken from the back)
    };
    uint32_t size_, mips_, layers_per_page_;
    uint64_t layer_bytes_;
    std::vector<Page> pages_;
};

}  // namespace strata::gl
