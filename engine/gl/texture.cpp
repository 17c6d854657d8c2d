// Texture: immutable storage, clearing, read-back and unit binding through direct state access.
#include "engine/gl/texture.h"

#include <algorithm>

namespace strata::gl {

Texture::Texture(GLenum internal_format, int width, int height, int samples)
    : internal_format_(internal_format), width_(width), height_(height), samples_(samples) {
    GLuint name = 0;
    glCreateTextures(samples > 1 ? GL_TEXTURE_2D_MULTISAMPLE : GL_TEXTURE_2D, 1, &name);
    name_ = ObjectName<DeleteTexture>(name);
    if (samples > 1) {
        glTextureStorage2DMultisample(name, samples, internal_format, width, height, GL_TRUE);
    } else {
        glTextureStorage2D(name, 1, internal_format, width, height);
        // Texel-exact sampling; integer formats are incomplete (read as zero) with a linear filter.
        glTextureParameteri(name, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTextureParameteri(name, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        glTextureParameteri(name, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(name, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    check_gl("creating a texture");
}

Texture Texture::srgb_image(std::span<const uint8_t> rgba, int width, int height) {
    Texture texture;
    texture.internal_format_ = GL_SRGB8_ALPHA8;  // not SRGB8: GL makes mips only of colour-renderable formats
    texture.width_ = width, texture.height_ = height, texture.samples_ = 1;
    GLuint name = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &name);
    texture.name_ = ObjectName<DeleteTexture>(name);
    int mips = 1;
    while ((std::max(width, height) >> mips) > 0) ++mips;
    glTextureStorage2D(name, mips, GL_SRGB8_ALPHA8, width, height);
    glTextureSubImage2D(name, 0, 0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    glGenerateTextureMipmap(name);
    glTextureParameteri(name, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(name, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(name, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(name, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    check_gl("creating an sRGB image texture");
    return texture;
}

void Texture::clear(GLenum format, GLenum type, const void* value) { glClearTexImage(id(), 0, format, type, value); }

void Texture::read(GLenum format, GLenum type, void* out, std::size_t size_bytes) const {
    glGetTextureImage(id(), 0, format, type, static_cast<GLsizei>(size_bytes), out);
    check_gl("glGetTextureImage");
}

void Texture::bind_image(GLuint unit, GLenum access) const {
    glBindImageTexture(unit, id(), 0, GL_FALSE, 0, access, internal_format_);
}

}  // namespace strata::gl
