#include "engine/gl/texture_layers.h"

#include <algorithm>
#include <bit>
#include <stdexcept>
#include <string>

namespace strata::gl {
namespace {

uint64_t bc1_bytes(uint32_t size) { return uint64_t(std::max(size, 4u) / 4) * (std::max(size, 4u) / 4) * 8; }

}  // namespace

bool TextureLayers::supported() {
    return epoxy_has_gl_extension("GL_EXT_texture_compression_s3tc") &&
           (epoxy_has_gl_extension("GL_EXT_texture_sRGB") || epoxy_has_gl_extension("GL_EXT_texture_compression_s3tc_srgb"));
}

TextureLayers::TextureLayers(uint32_t size, uint64_t page_bytes) : size_(size), mips_(uint32_t(std::bit_width(size)) - 2) {
    if (!supported()) throw std::runtime_error("this OpenGL driver cannot sample BC1 (S3TC) sRGB textures, which textured models need");
    layer_bytes_ = 0;
    for (uint32_t m = 0; m < mips_; ++m) layer_bytes_ += bc1_bytes(size >> m);
    GLint most = 0;
    glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &most);
    layers_per_page_ = uint32_t(std::clamp<uint64_t>(page_bytes / layer_bytes_, 1, uint64_t(std::max(most, 1))));
}

TextureLayers::Layer TextureLayers::allocate() {
    for (uint32_t p = 0; p < pages_.size(); ++p)
        if (!pages_[p].free.empty()) {
            const uint32_t layer = pages_[p].free.back();
            pages_[p].free.pop_back();
            return {p, layer};
        }
    GLuint name = 0;
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &name);
    Page page{ObjectName<DeleteTexture>(name), {}};
    glTextureStorage3D(name, GLsizei(mips_), GL_COMPRESSED_SRGB_S3TC_DXT1_EXT, GLsizei(size_), GLsizei(size_), GLsizei(layers_per_page_));
    glTextureParameteri(name, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(name, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(name, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(name, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTextureParameteri(name, GL_TEXTURE_MAX_LEVEL, GLint(mips_ - 1));
    // Ground seen at a grazing angle keeps its detail along the view (core in OpenGL 4.6).
    if (epoxy_gl_version() >= 46 || epoxy_has_gl_extension("GL_EXT_texture_filter_anisotropic"))
        glTextureParameterf(name, GL_TEXTURE_MAX_ANISOTROPY, 8.0f);
    check_gl("creating a page of texture layers");
    for (uint32_t l = layers_per_page_; l-- > 1;) page.free.push_back(l);
    pages_.push_back(std::move(page));
    return {uint32_t(pages_.size() - 1), 0};
}

void TextureLayers::free(Layer& layer) {
    if (!layer) return;
    pages_[layer.page].free.push_back(layer.layer);
    // Give the last pages back once they are empty.
    while (!pages_.empty() && pages_.back().free.size() == layers_per_page_) pages_.pop_back();
    layer = {};
}

void TextureLayers::upload(Layer layer, std::span<const uint8_t> chain) {
    if (chain.size() != layer_bytes_) throw std::invalid_argument("TextureLayers::upload: " + std::to_string(chain.size()) + " bytes for a layer of " + std::to_string(layer_bytes_));
    uint64_t at = 0;
    for (uint32_t m = 0; m < mips_; ++m) {
        const uint32_t s = size_ >> m;
        glCompressedTextureSubImage3D(page(layer.page), GLint(m), 0, 0, GLint(layer.layer), GLsizei(s), GLsizei(s), 1, GL_COMPRESSED_SRGB_S3TC_DXT1_EXT,
                                      GLsizei(bc1_bytes(s)), chain.data() + at);
        at += bc1_bytes(s);
    }
    check_gl("uploading a texture layer");
}

}  // namespace strata::gl
