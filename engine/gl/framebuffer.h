// Off-screen render targets of any size, optionally multisampled: linear RGBA16F colour, 32-bit float
// depth, and optional data channels for the renderer's EXR output (normals, HLOD level, node id).
//
// REVERSED Z: depth is cleared to 0 (far) and bind() sets the GL_GREATER / GL_ZERO_TO_ONE state of
// depth_convention.h. Projections must come from reversed_z_perspective().
//
// Multisampling: colour is the average of the samples (a box-filter resolve, as a blit would do).
// Depth, normals, level and node id are data, which averaging would corrupt (half of node 7 and half of
// node 9 is not node 8): each pixel takes all four from one sample, the one nearest the camera, so
// they describe the same surface point. A compute pass does both, independently of blend, scissor and
// mask state.
#pragma once

#include <glm/vec4.hpp>

#include <cstdint>
#include <vector>

#include "engine/gl/gl.h"
#include "engine/gl/object_name.h"
#include "engine/gl/program.h"
#include "engine/gl/texture.h"

namespace strata::gl {

struct FramebufferFormat {
    int width = 0;
    int height = 0;
    int samples = 1;       // 1, 2, 4 or 8; lowered to what the driver supports for these attachments
    bool normals = false;  // RGBA16F, xyz read back
    bool level = false;    // R32F: the HLOD level drawn there
    bool node_id = false;  // R32UI: which node drew the pixel
};

// Fragment shader outputs. Locations are fixed whichever attachments exist: writes to an absent one are
// discarded, so one shader serves every format. An attachment that exists but is not written holds
// undefined values.
inline constexpr GLuint color_output = 0;
inline constexpr GLuint normal_output = 1;
inline constexpr GLuint level_output = 2;
inline constexpr GLuint node_id_output = 3;
inline constexpr const char* fragment_outputs_glsl = R"(
layout(location = 0) out vec4 out_color;    // linear RGBA
layout(location = 1) out vec4 out_normal;   // xyz: unit normal
layout(location = 2) out float out_level;   // HLOD level
layout(location = 3) out uint out_node_id;  // node id
)";

// What clear() leaves in the data channels: "nothing drawn here".
inline constexpr float no_level = -1.0f;
inline constexpr std::uint32_t no_node_id = 0;

class Framebuffer {
public:
    // Creates the attachments, checks completeness and clears to transparent black. Throws GlError
    // for a bad size or sample count, or an incomplete framebuffer.
    explicit Framebuffer(const FramebufferFormat& format);

    // Binds for drawing, sets the viewport to the whole target and the reversed-Z depth state.
    void bind();
    // Colour to `color`; depth to far_plane_depth; normals to 0; level to no_level; node id to
    // no_node_id. Not affected by the scissor test or write masks.
    void clear(const glm::vec4& color);

    // Read-back, ROWS TOP TO BOTTOM (GL's are bottom to top), channels interleaved. A multisampled
    // target is resolved first when it was bound or cleared since the last resolve; the resolve
    // changes the current program, texture units 0-4 and image units 0-4. Reading assumes the default
    // pixel-pack state (no pack buffer, alignment 4 or less). Throws GlError for an absent channel.
    std::vector<float> read_color();          // RGBA, 4 per pixel
    std::vector<float> read_depth();          // window-space depth (reversed Z), 1 per pixel
    std::vector<float> read_normals();        // xyz, 3 per pixel
    std::vector<float> read_level();          // 1 per pixel
    std::vector<std::uint32_t> read_node_id();  // 1 per pixel

    int width() const { return format_.width; }
    int height() const { return format_.height; }
    int samples() const { return format_.samples; }  // after clamping to the driver's limit
    const FramebufferFormat& format() const { return format_; }
    GLuint id() const { return framebuffer_.get(); }

private:
    // An attachment as drawn into, and (multisampled only) its single-sample copy made by resolve().
    struct Channel {
        Texture drawn;
        Texture resolved;
    };

    void create_attachments();
    void attach();
    void create_resolve_pass();
    void resolve_if_pending();
    const Texture& readable(const Channel& channel, bool present, const char* name);
    template <class T>
    std::vector<T> read(const Texture& texture, int components, GLenum format, GLenum type) const;

    FramebufferFormat format_;
    ObjectName<DeleteFramebuffer> framebuffer_;
    Channel color_, depth_, normals_, level_, node_id_;
    Program resolve_program_;  // multisampled only
    bool resolve_pending_ = false;
};

}  // namespace strata::gl
