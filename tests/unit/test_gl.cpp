// The OpenGL backend on a real driver (Mesa's llvmpipe through EGL, no display, no mocks): contexts,
// buffers, programs, framebuffers with and without multisampling, read-back orientation and depth.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <glm/glm.hpp>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/gl/buffer.h"
#include "engine/gl/context.h"
#include "engine/gl/depth_convention.h"
#include "engine/gl/framebuffer.h"
#include "engine/gl/gl.h"
#include "engine/gl/program.h"
#include "engine/gl/vertex_array.h"

namespace strata::gl {
namespace {

using ::testing::ContainsRegex;
using ::testing::HasSubstr;

// Sets (or, given null, unsets) an environment variable until the end of the scope.
class ScopedEnvironment {
public:
    ScopedEnvironment(const char* name, const char* value) : name_(name) {
        if (const char* old = std::getenv(name)) old_value_ = old;
        if (value) setenv(name, value, 1);
        else unsetenv(name);
    }
    ~ScopedEnvironment() {
        if (old_value_) setenv(name_, old_value_->c_str(), 1);
        else unsetenv(name_);
    }

private:
    const char* name_;
    std::optional<std::string> old_value_;
};

// The message of the GlError that `action` throws, or "" when it throws none.
template <class Action>
std::string gl_error_message(Action action) {
    try {
        action();
    } catch (const GlError& error) {
        return error.what();
    }
    return "";
}

class GlTest : public ::testing::Test {
protected:
    void SetUp() override { context_ = create_headless_context(); }
    std::unique_ptr<Context> context_;
};

// --- contexts ---

TEST_F(GlTest, HeadlessContextIsOpenGl45CoreWithADriverName) {
    EXPECT_GE(epoxy_gl_version(), 45) << context_->version();
    GLint profile = 0;
    glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
    EXPECT_TRUE(profile & GL_CONTEXT_CORE_PROFILE_BIT);
    EXPECT_FALSE(context_->renderer().empty());
    EXPECT_THAT(context_->version(), HasSubstr("4."));
    EXPECT_THAT(context_->platform(), HasSubstr("EGL"));
    EXPECT_EQ(context_->framebuffer_size(), glm::ivec2(0, 0));
    EXPECT_EQ(context_->window(), nullptr);
}

TEST(HeadlessContext, DevicePlatformCanBeForced) {
    // Mesa offers its software renderer as an EGL device too; NVIDIA's headless path is this one.
    const ScopedEnvironment platform("STRATA_EGL_PLATFORM", "device");
    const auto context = create_headless_context();
    EXPECT_THAT(context->platform(), HasSubstr("EGL device"));
    EXPECT_GE(epoxy_gl_version(), 45);
}

TEST(HeadlessContext, UnknownForcedPlatformIsRejected) {
    const ScopedEnvironment platform("STRATA_EGL_PLATFORM", "wayland");
    EXPECT_THAT(gl_error_message([] { create_headless_context(); }),
                HasSubstr("STRATA_EGL_PLATFORM=wayland: expected surfaceless, device or default"));
}

TEST(HeadlessContext, FailureNamesThePlatformAndTheEglError) {
    // Mesa's default display is an X11 one here, and there is no X server to open.
    const ScopedEnvironment platform("STRATA_EGL_PLATFORM", "default"), mesa_platform("EGL_PLATFORM", "x11"),
        x11("DISPLAY", nullptr), wayland("WAYLAND_DISPLAY", nullptr);
    std::string message;
    try {
        create_headless_context();
        GTEST_SKIP() << "this EGL's default display needs no window system (NVIDIA's does not)";
    } catch (const GlError& error) {
        message = error.what();
    }
    EXPECT_EQ(message, "no OpenGL 4.5 core context through EGL; tried:\n  default: eglInitialize failed: EGL_NOT_INITIALIZED");
}

TEST(WindowContext, WithoutADisplaySaysSo) {
    const ScopedEnvironment x11("DISPLAY", nullptr), wayland("WAYLAND_DISPLAY", nullptr);
    EXPECT_EQ(gl_error_message([] { create_window_context("no display", 64, 48); }),
              "no display (DISPLAY is not set): use the headless renderer or run under Xvfb");
}

// --- buffers and programs ---

TEST_F(GlTest, BufferUploadAndDownloadRoundTrip) {
    std::vector<std::uint32_t> values(1000);
    for (std::uint32_t i = 0; i < values.size(); ++i) values[i] = 3 * i + 1;
    Buffer buffer(values, GL_DYNAMIC_STORAGE_BIT);
    EXPECT_EQ(buffer.size(), 4000u);
    const std::vector<std::uint32_t> patch = {7, 8, 9};
    buffer.upload(patch, 10 * sizeof(std::uint32_t));
    std::copy(patch.begin(), patch.end(), values.begin() + 10);
    EXPECT_EQ(buffer.download<std::uint32_t>(values.size()), values);
    EXPECT_EQ(buffer.download<std::uint32_t>(2, 11 * sizeof(std::uint32_t)), (std::vector<std::uint32_t>{8, 9}));
    check_gl("buffer round trip");

    EXPECT_THAT(gl_error_message([&] { buffer.upload(patch, 3990); }),
                HasSubstr("bytes [3990, 4002) outside the buffer's 4000 bytes"));
    Buffer fixed(values, 0);
    EXPECT_THAT(gl_error_message([&] { fixed.upload(patch); }), HasSubstr("without GL_DYNAMIC_STORAGE_BIT"));
}

TEST_F(GlTest, ComputeProgramWritesAStorageBuffer) {
    const Program program = Program::compute("squares", R"(#version 450 core
        layout(local_size_x = 64) in;
        layout(std430, binding = 3) writeonly buffer Squares { uint squares[]; };
        uniform uint offset;
        void main() { uint i = gl_GlobalInvocationID.x; squares[i] = i * i + offset; })");
    Buffer squares(256 * sizeof(std::uint32_t), 0);
    squares.bind_base(GL_SHADER_STORAGE_BUFFER, 3);
    program.set("offset", 5u);
    program.use();
    glDispatchCompute(4, 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    const auto values = squares.download<std::uint32_t>(256);
    for (std::uint32_t i = 0; i < 256; ++i) ASSERT_EQ(values[i], i * i + 5) << i;
    check_gl("compute");
}

TEST_F(GlTest, CompileErrorNamesProgramStageAndLine) {
    const char* vertex = "#version 450 core\nvoid main() { gl_Position = vec4(0.0); }\n";
    const char* fragment =
        "#version 450 core\n"
        "out vec4 color;\n"
        "void main() {\n"
        "    color = vec4(1.0) +;\n"  // line 4
        "}\n";
    const std::string message = gl_error_message([&] { Program::graphics("broken_test_program", vertex, fragment); });
    EXPECT_THAT(message, HasSubstr("'broken_test_program'"));
    EXPECT_THAT(message, HasSubstr("fragment shader does not compile"));
    EXPECT_THAT(message, ContainsRegex("0[:(]4[^0-9]"));  // Mesa "0:4(23): error", NVIDIA "0(4) : error"
}

TEST_F(GlTest, LinkErrorNamesProgram) {
    const char* vertex = "#version 450 core\nvoid main() { gl_Position = vec4(0.0); }\n";
    const char* fragment = "#version 450 core\nin vec3 never_written;\nout vec4 color;\n"
                           "void main() { color = vec4(never_written, 1.0); }\n";
    const std::string message = gl_error_message([&] { Program::graphics("unlinkable", vertex, fragment); });
    EXPECT_THAT(message, HasSubstr("GL program 'unlinkable' does not link"));
    EXPECT_THAT(message, HasSubstr("never_written"));
}

// --- framebuffers ---

TEST_F(GlTest, ClearReadsBackExactlyAtAnOddSize) {
    Framebuffer framebuffer({.width = 37, .height = 23, .normals = true, .level = true, .node_id = true});
    framebuffer.clear({0.25f, 0.5f, 0.75f, 1.0f});
    const std::vector<float> color = framebuffer.read_color();
    ASSERT_EQ(color.size(), 37u * 23u * 4u);
    for (std::size_t i = 0; i < color.size(); i += 4)
        ASSERT_EQ((glm::vec4(color[i], color[i + 1], color[i + 2], color[i + 3])),
                  glm::vec4(0.25f, 0.5f, 0.75f, 1.0f)) << "pixel " << i / 4;
    EXPECT_EQ(framebuffer.read_depth(), std::vector<float>(37 * 23, far_plane_depth));
    EXPECT_EQ(framebuffer.read_normals(), std::vector<float>(37 * 23 * 3, 0.0f));
    EXPECT_EQ(framebuffer.read_level(), std::vector<float>(37 * 23, no_level));
    EXPECT_EQ(framebuffer.read_node_id(), std::vector<std::uint32_t>(37 * 23, no_node_id));
}

TEST_F(GlTest, FramebufferRejectsBadFormats) {
    EXPECT_THAT(gl_error_message([] { Framebuffer({.width = 0, .height = 8}); }), HasSubstr("each side must be 1 to"));
    EXPECT_THAT(gl_error_message([] { Framebuffer({.width = 8, .height = 8, .samples = 3}); }),
                HasSubstr("samples must be 1, 2, 4 or 8"));
    Framebuffer plain({.width = 8, .height = 8});
    EXPECT_THAT(gl_error_message([&] { plain.read_node_id(); }), HasSubstr("has no node id attachment"));
}

// A triangle drawn the way the renderer draws: positions pulled from a storage buffer by gl_VertexID,
// no vertex attributes, an empty vertex array; every output channel written.
class StorageBufferTriangle {
public:
    static constexpr std::uint32_t node_id = 42;
    static constexpr float level = 3.0f;
    static constexpr glm::vec4 color{1.0f, 0.5f, 0.25f, 1.0f};

    // The triangle whose corners land on `ndc_corners` (normalized device x, y) at `distance` in
    // front of the eye, through `projection`.
    StorageBufferTriangle(const glm::dmat4& projection, const std::vector<glm::vec2>& ndc_corners, double distance)
        : projection_(projection) {
        std::vector<glm::vec4> eye_positions;
        for (const glm::vec2& ndc : ndc_corners)
            eye_positions.emplace_back(ndc.x * distance / projection[0][0], ndc.y * distance / projection[1][1],
                                       -distance, 1.0);
        vertices_ = Buffer(eye_positions, 0);
    }

    void draw(Framebuffer& framebuffer) {
        framebuffer.bind();
        program_.set("projection", glm::mat4(projection_));
        program_.set("color", color);
        program_.use();
        vertices_.bind_base(GL_SHADER_STORAGE_BUFFER, 0);
        empty_.bind();
        glDrawArrays(GL_TRIANGLES, 0, 3);
        check_gl("drawing the test triangle");
    }

private:
    static constexpr const char* vertex_source = R"(#version 450 core
        layout(std430, binding = 0) readonly buffer Vertices { vec4 eye_positions[]; };
        uniform mat4 projection;
        void main() { gl_Position = projection * eye_positions[gl_VertexID]; })";
    static std::string fragment_source() {
        return std::string("#version 450 core\n") + fragment_outputs_glsl + R"(
        uniform vec4 color;
        void main() {
            out_color = color;
            out_normal = vec4(0.0, 0.0, 1.0, 0.0);
            out_level = 3.0;
            out_node_id = 42u;
        })";
    }

    glm::dmat4 projection_;
    Program program_ = Program::graphics("test triangle", vertex_source, fragment_source());
    Buffer vertices_;
    VertexArray empty_ = VertexArray::create();
};

TEST_F(GlTest, TriangleFromStorageBufferLandsTopLeftWithEveryChannel) {
    const int width = 64, height = 48;
    const double near = 0.5, far = 100.0, distance = 5.0;
    const glm::dmat4 projection = reversed_z_perspective(glm::radians(60.0), double(width) / height, near, far);
    // The top-left quarter of clip space, cut along its diagonal: the upper-left half of that quarter.
    StorageBufferTriangle triangle(projection, {{-1, 1}, {-1, 0}, {0, 1}}, distance);
    Framebuffer framebuffer({.width = width, .height = height, .normals = true, .level = true, .node_id = true});
    framebuffer.clear({0, 0, 0, 0});
    triangle.draw(framebuffer);

    const auto color = framebuffer.read_color();
    const auto depth = framebuffer.read_depth();
    const auto normals = framebuffer.read_normals();
    const auto level = framebuffer.read_level();
    const auto node_id = framebuffer.read_node_id();
    const auto at = [&](int x, int y) { return std::size_t(y) * width + x; };  // y = 0 is the top row
    const auto rgba = [&](int x, int y) { const float* p = &color[4 * at(x, y)]; return glm::vec4(p[0], p[1], p[2], p[3]); };

    const int covered = at(3, 2);
    EXPECT_EQ(rgba(3, 2), StorageBufferTriangle::color);
    EXPECT_EQ(glm::vec3(normals[3 * covered], normals[3 * covered + 1], normals[3 * covered + 2]), glm::vec3(0, 0, 1));
    EXPECT_EQ(level[covered], StorageBufferTriangle::level);
    EXPECT_EQ(node_id[covered], StorageBufferTriangle::node_id);
    EXPECT_NEAR(eye_distance_from_depth(depth[covered], near, far), distance, 1e-5 * distance);

    // Empty: the bottom-left (where an unflipped image would show the triangle), the right half, and
    // the lower-right part of the top-left quarter.
    const std::pair<int, int> empty_pixels[] = {{3, height - 3}, {width - 3, 2}, {width - 3, height - 3}, {28, 20}};
    for (const auto& [x, y] : empty_pixels) {
        EXPECT_EQ(rgba(x, y), glm::vec4(0)) << x << "," << y;
        EXPECT_EQ(depth[at(x, y)], far_plane_depth);
        EXPECT_EQ(level[at(x, y)], no_level);
        EXPECT_EQ(node_id[at(x, y)], no_node_id);
    }
}

TEST_F(GlTest, Msaa4xAveragesEdgeColourAndKeepsDataChannelsUnblended) {
    const int size = 32;
    const double near = 0.5, distance = 4.0;
    const glm::dmat4 projection = reversed_z_perspective(glm::radians(90.0), 1.0, near);  // infinite far
    // The half of clip space above the diagonal y = x: in image rows (top first), pixel (x, y) is
    // inside for x + y < 31, crossed by the edge for x + y = 31, outside beyond.
    StorageBufferTriangle triangle(projection, {{-1, 1}, {-1, -1}, {1, 1}}, distance);
    Framebuffer framebuffer({.width = size, .height = size, .samples = 4, .level = true, .node_id = true});
    ASSERT_EQ(framebuffer.samples(), 4);
    framebuffer.clear({0, 0, 0, 0});
    triangle.draw(framebuffer);

    const auto color = framebuffer.read_color();
    const auto depth = framebuffer.read_depth();
    const auto level = framebuffer.read_level();
    const auto node_id = framebuffer.read_node_id();
    for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
            const std::size_t i = std::size_t(y) * size + x;
            const float red = color[4 * i];
            if (x + y <= 29) {
                ASSERT_EQ(red, 1.0f) << x << "," << y;
                ASSERT_EQ(color[4 * i + 2], 0.25f) << x << "," << y;
            } else if (x + y >= 33) {
                ASSERT_EQ(red, 0.0f) << x << "," << y;
                ASSERT_EQ(node_id[i], no_node_id) << x << "," << y;
            } else if (x + y == 31) {
                EXPECT_GT(red, 0.0f) << x << "," << y;
                EXPECT_LT(red, 1.0f) << x << "," << y;
                // Partly covered: the data channels come whole from the triangle's (nearer) samples.
                EXPECT_EQ(node_id[i], StorageBufferTriangle::node_id) << x << "," << y;
                EXPECT_EQ(level[i], StorageBufferTriangle::level) << x << "," << y;
                EXPECT_NEAR(eye_distance_from_depth(depth[i], near), distance, 1e-5 * distance);
            }
        }
    }
}

// --- the depth convention, on the CPU ---

TEST(DepthConvention, EyeDistanceInvertsTheProjection) {
    for (const double far : {100.0, infinite_far}) {
        const glm::dmat4 projection = reversed_z_perspective(glm::radians(50.0), 1.5, 0.25, far);
        const auto depth_at = [&](double distance) {
            const glm::dvec4 clip = projection * glm::dvec4(0.3, -0.2, -distance, 1.0);
            return clip.z / clip.w;
        };
        EXPECT_NEAR(depth_at(0.25), near_plane_depth, 1e-12);
        EXPECT_NEAR(depth_at(std::isinf(far) ? 1e15 : far), far_plane_depth, 1e-12);
        for (const double distance : {0.25, 1.0, 7.3, 99.0})
            EXPECT_NEAR(eye_distance_from_depth(depth_at(distance), 0.25, far), distance, 1e-9 * distance);
    }
    EXPECT_EQ(eye_distance_from_depth(far_plane_depth, 0.25), infinite_far);
}

}  // namespace
}  // namespace strata::gl
