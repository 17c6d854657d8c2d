// Framebuffer: attachments, completeness, clearing, the multisample resolve pass and read-back.
#include "engine/gl/framebuffer.h"

#include <algorithm>
#include <string>

#include "engine/gl/depth_convention.h"

namespace strata::gl {
namespace {

// Per pixel: colour averaged over the samples; depth, normal, level and node id all taken from the
// sample nearest the camera (largest reversed-Z depth; the first one on ties, so sample 0 where
// nothing was drawn).
constexpr const char* resolve_source = R"(
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) uniform sampler2DMS color_samples;
layout(binding = 0, rgba16f) writeonly uniform image2D color_resolved;
layout(binding = 1) uniform sampler2DMS depth_samples;
layout(binding = 1, r32f) writeonly uniform image2D depth_resolved;
#ifdef HAS_NORMALS
layout(binding = 2) uniform sampler2DMS normal_samples;
layout(binding = 2, rgba16f) writeonly uniform image2D normal_resolved;
#endif
#ifdef HAS_LEVEL
layout(binding = 3) uniform sampler2DMS level_samples;
layout(binding = 3, r32f) writeonly uniform image2D level_resolved;
#endif
#ifdef HAS_NODE_ID
layout(binding = 4) uniform usampler2DMS node_id_samples;
layout(binding = 4, r32ui) writeonly uniform uimage2D node_id_resolved;
#endif

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, imageSize(color_resolved)))) return;
    vec4 color_sum = vec4(0.0);
    int nearest = 0;
    float nearest_depth = -1.0;
    for (int s = 0; s < SAMPLES; ++s) {
        color_sum += texelFetch(color_samples, pixel, s);
        float depth = texelFetch(depth_samples, pixel, s).r;
        if (depth > nearest_depth) {
            nearest_depth = depth;
            nearest = s;
        }
    }
    imageStore(color_resolved, pixel, color_sum / float(SAMPLES));
    imageStore(depth_resolved, pixel, vec4(nearest_depth));
#ifdef HAS_NORMALS
    imageStore(normal_resolved, pixel, texelFetch(normal_samples, pixel, nearest));
#endif
#ifdef HAS_LEVEL
    imageStore(level_resolved, pixel, texelFetch(level_samples, pixel, nearest));
#endif
#ifdef HAS_NODE_ID
    imageStore(node_id_resolved, pixel, texelFetch(node_id_samples, pixel, nearest));
#endif
}
)";
constexpr int resolve_group_size = 8;

GLint get_integer(GLenum name) {
    GLint value = 0;
    glGetIntegerv(name, &value);
    return value;
}

const char* framebuffer_status_name(GLenum status) {
    switch (status) {
        case GL_FRAMEBUFFER_UNDEFINED: return "GL_FRAMEBUFFER_UNDEFINED";
        case GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT: return "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT";
        case GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT: return "GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT";
        case GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER: return "GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER";
        case GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER: return "GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER";
        case GL_FRAMEBUFFER_UNSUPPORTED: return "GL_FRAMEBUFFER_UNSUPPORTED";
        case GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE: return "GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE";
        case GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS: return "GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS";
    }
    return "an unknown framebuffer status";
}

std::string describe(const FramebufferFormat& format) {
    return std::to_string(format.width) + "×" + std::to_string(format.height) + " framebuffer with " +
           std::to_string(format.samples) + " sample(s)";
}

void check_size(const FramebufferFormat& format) {
    const int largest = std::min({get_integer(GL_MAX_TEXTURE_SIZE), get_integer(GL_MAX_FRAMEBUFFER_WIDTH),
                                  get_integer(GL_MAX_FRAMEBUFFER_HEIGHT)});
    if (format.width < 1 || format.height < 1 || format.width > largest || format.height > largest)
        throw GlError(describe(format) + ": each side must be 1 to " + std::to_string(largest) + " pixels");
}

// The requested count lowered to what every attachment format supports.
int supported_samples(const FramebufferFormat& format) {
    if (format.samples != 1 && format.samples != 2 && format.samples != 4 && format.samples != 8)
        throw GlError(describe(format) + ": samples must be 1, 2, 4 or 8");
    int limit = std::min({get_integer(GL_MAX_SAMPLES), get_integer(GL_MAX_COLOR_TEXTURE_SAMPLES),
                          get_integer(GL_MAX_DEPTH_TEXTURE_SAMPLES)});
    if (format.node_id) limit = std::min(limit, get_integer(GL_MAX_INTEGER_SAMPLES));
    return std::max(1, std::min(format.samples, limit));
}

template <class T>
void flip_rows(std::vector<T>& values, std::size_t row_length, std::size_t rows) {
    for (std::size_t top = 0, bottom = rows - 1; top < bottom; ++top, --bottom)
        std::swap_ranges(values.begin() + top * row_length, values.begin() + (top + 1) * row_length,
                         values.begin() + bottom * row_length);
}

}  // namespace

Framebuffer::Framebuffer(const FramebufferFormat& format) : format_(format) {
    check_size(format_);
    format_.samples = supported_samples(format_);
    create_attachments();
    attach();
    if (format_.samples > 1) create_resolve_pass();
    clear(glm::vec4(0.0f));
}

void Framebuffer::create_attachments() {
    const int w = format_.width, h = format_.height, samples = format_.samples;
    const bool multisampled = samples > 1;
    auto make = [&](Channel& channel, GLenum drawn_format, GLenum resolved_format) {
        channel.drawn = Texture(drawn_format, w, h, samples);
        if (multisampled) channel.resolved = Texture(resolved_format, w, h);
    };
    make(color_, GL_RGBA16F, GL_RGBA16F);
    // The resolved depth is a colour texture: the compute pass writes it as an image, which depth
    // formats cannot be.
    make(depth_, GL_DEPTH_COMPONENT32F, GL_R32F);
    if (format_.normals) make(normals_, GL_RGBA16F, GL_RGBA16F);
    if (format_.level) make(level_, GL_R32F, GL_R32F);
    if (format_.node_id) make(node_id_, GL_R32UI, GL_R32UI);
}

void Framebuffer::attach() {
    GLuint name = 0;
    glCreateFramebuffers(1, &name);
    framebuffer_ = ObjectName<DeleteFramebuffer>(name);
    const Channel* outputs[] = {&color_, &normals_, &level_, &node_id_};  // in output-location order
    GLenum draw_buffers[std::size(outputs)];
    for (std::size_t i = 0; i < std::size(outputs); ++i) {
        const GLuint texture = outputs[i]->drawn.id();
        draw_buffers[i] = texture ? GL_COLOR_ATTACHMENT0 + static_cast<GLenum>(i) : GL_NONE;
        if (texture) glNamedFramebufferTexture(name, draw_buffers[i], texture, 0);
    }
    glNamedFramebufferTexture(name, GL_DEPTH_ATTACHMENT, depth_.drawn.id(), 0);
    glNamedFramebufferDrawBuffers(name, static_cast<GLsizei>(std::size(draw_buffers)), draw_buffers);
    glNamedFramebufferReadBuffer(name, GL_COLOR_ATTACHMENT0);
    check_gl("attaching framebuffer textures");
    const GLenum status = glCheckNamedFramebufferStatus(name, GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        throw GlError(describe(format_) + " is incomplete: " + framebuffer_status_name(status));
}

void Framebuffer::create_resolve_pass() {
    std::string header = "#version 450 core\n#define SAMPLES " + std::to_string(format_.samples) + "\n";
    if (format_.normals) header += "#define HAS_NORMALS\n";
    if (format_.level) header += "#define HAS_LEVEL\n";
    if (format_.node_id) header += "#define HAS_NODE_ID\n";
    resolve_program_ = Program::compute("framebuffer resolve", header + resolve_source);
}

void Framebuffer::bind() {
    glBindFramebuffer(GL_FRAMEBUFFER, id());
    glViewport(0, 0, format_.width, format_.height);
    use_reversed_z_depth();
    resolve_pending_ = true;
}

void Framebuffer::clear(const glm::vec4& color) {
    const glm::vec4 no_normal(0.0f);
    color_.drawn.clear(GL_RGBA, GL_FLOAT, &color);
    depth_.drawn.clear(GL_DEPTH_COMPONENT, GL_FLOAT, &far_plane_depth);
    if (format_.normals) normals_.drawn.clear(GL_RGBA, GL_FLOAT, &no_normal);
    if (format_.level) level_.drawn.clear(GL_RED, GL_FLOAT, &no_level);
    if (format_.node_id) node_id_.drawn.clear(GL_RED_INTEGER, GL_UNSIGNED_INT, &no_node_id);
    check_gl("clearing a framebuffer");
    resolve_pending_ = true;
}

void Framebuffer::resolve_if_pending() {
    if (format_.samples == 1 || !resolve_pending_) return;
    resolve_program_.use();
    GLuint unit = 0;
    for (const Channel* channel : {&color_, &depth_, &normals_, &level_, &node_id_}) {
        if (channel->drawn.id()) {
            channel->drawn.bind_unit(unit);
            channel->resolved.bind_image(unit, GL_WRITE_ONLY);
        }
        ++unit;
    }
    glDispatchCompute((format_.width + resolve_group_size - 1) / resolve_group_size,
                      (format_.height + resolve_group_size - 1) / resolve_group_size, 1);
    // Image stores are incoherent: make them visible to read-back, sampling and blits.
    glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
    check_gl("resolving a multisampled framebuffer");
    resolve_pending_ = false;
}

const Texture& Framebuffer::readable(const Channel& channel, bool present, const char* name) {
    if (!present) throw GlError(describe(format_) + " has no " + name + " attachment");
    resolve_if_pending();
    return format_.samples > 1 ? channel.resolved : channel.drawn;
}

template <class T>
std::vector<T> Framebuffer::read(const Texture& texture, int components, GLenum format, GLenum type) const {
    const auto row_length = static_cast<std::size_t>(format_.width) * static_cast<std::size_t>(components);
    const auto rows = static_cast<std::size_t>(format_.height);
    std::vector<T> values(row_length * rows);
    texture.read(format, type, values.data(), values.size() * sizeof(T));
    flip_rows(values, row_length, rows);
    return values;
}

std::vector<float> Framebuffer::read_color() {
    return read<float>(readable(color_, true, "colour"), 4, GL_RGBA, GL_FLOAT);
}

std::vector<float> Framebuffer::read_depth() {
    const Texture& texture = readable(depth_, true, "depth");
    return read<float>(texture, 1, format_.samples > 1 ? GL_RED : GL_DEPTH_COMPONENT, GL_FLOAT);
}

std::vector<float> Framebuffer::read_normals() {
    return read<float>(readable(normals_, format_.normals, "normals"), 3, GL_RGB, GL_FLOAT);
}

std::vector<float> Framebuffer::read_level() {
    return read<float>(readable(level_, format_.level, "level"), 1, GL_RED, GL_FLOAT);
}

std::vector<std::uint32_t> Framebuffer::read_node_id() {
    return read<std::uint32_t>(readable(node_id_, format_.node_id, "node id"), 1, GL_RED_INTEGER, GL_UNSIGNED_INT);
}

}  // namespace strata::gl
