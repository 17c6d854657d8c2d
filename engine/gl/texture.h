// 2D textures with immutable storage, single- or multisampled: the attachments of Framebuffer and the
// images its resolve pass writes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "engine/gl/gl.h"
#include "engine/gl/object_name.h"

namespace strata::gl {

class Texture {
public:
    Texture() = default;  // no texture
    // One mip level of `internal_format` (GL_RGBA16F, GL_DEPTH_COMPONENT32F, ...); samples > 1 makes a
    // GL_TEXTURE_2D_MULTISAMPLE with the standard sample positions.
    Texture(GLenum internal_format, int width, int height, int samples = 1);
    // An 8-bit sRGB image (RGBA, rows from the bottom) with its whole mip chain, sampled trilinearly in
    // linear light and clamped at its edges: an image a drawable samples, as the ground its imagery.
    static Texture srgb_image(std::span<const uint8_t> rgba, int width, int height);

    // Sets every texel (every sample) to `value`, given as `format`/`type` (glClearTexImage): unlike
    // glClear, not affected by the scissor test, write masks or the bound framebuffer.
    void clear(GLenum format, GLenum type, const void* value);
    // Copies the texels into `out` (rows bottom to top, as GL stores them), converted to
    // `format`/`type`; single-sampled textures only. Assumes the default pixel-pack state.
    void read(GLenum format, GLenum type, void* out, std::size_t size_bytes) const;

    void bind_unit(GLuint unit) const { glBindTextureUnit(unit, id()); }
    // Binds level 0 to image unit `unit` for imageLoad/imageStore with the texture's own format.
    void bind_image(GLuint unit, GLenum access) const;

    GLuint id() const { return name_.get(); }
    GLenum internal_format() const { return internal_format_; }
    int width() const { return width_; }
    int height() const { return height_; }
    int samples() const { return samples_; }

private:
    ObjectName<DeleteTexture> name_;
    GLenum internal_format_ = 0;
    int width_ = 0;
    int height_ = 0;
    int samples_ = 0;
};

}  // namespace strata::gl
