// A GLFW window context on a real X server (ctest runs it on a private Xvfb, tests/support/with_xvfb.sh): draw into the default
// framebuffer, read it back, swap.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "engine/gl/context.h"
#include "engine/gl/gl.h"
#include "engine/gl/program.h"
#include "engine/gl/vertex_array.h"

namespace strata::gl {
namespace {

TEST(WindowContext, DrawsReadsBackAndSwaps) {
    const auto context = create_window_context("strata window test", 64, 48);
    EXPECT_EQ(context->platform(), "GLFW window");
    EXPECT_NE(context->window(), nullptr);
    EXPECT_GE(epoxy_gl_version(), 45) << context->version();
    const glm::ivec2 size = context->framebuffer_size();
    ASSERT_EQ(size, glm::ivec2(64, 48));

    // Blue background; a red triangle over the lower-left half, corners from gl_VertexID alone.
    const Program program = Program::graphics("window test", R"(#version 450 core
        void main() { gl_Position = vec4(gl_VertexID == 1 ? 1.0 : -1.0, gl_VertexID == 2 ? 1.0 : -1.0, 0.0, 1.0); })",
                                              R"(#version 450 core
        out vec4 color;
        void main() { color = vec4(1.0, 0.0, 0.0, 1.0); })");
    const VertexArray empty = VertexArray::create();
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, size.x, size.y);
    const float blue[] = {0.0f, 0.0f, 1.0f, 1.0f};
    glClearNamedFramebufferfv(0, GL_COLOR, 0, blue);
    program.use();
    empty.bind();
    glDrawArrays(GL_TRIANGLES, 0, 3);

    std::vector<std::uint8_t> pixels(std::size_t(size.x) * size.y * 4);
    glNamedFramebufferReadBuffer(0, GL_BACK);
    glReadPixels(0, 0, size.x, size.y, GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
    check_gl("drawing into the window");
    const auto rgb = [&](int x, int y) {  // GL rows: y = 0 at the bottom
        const std::uint8_t* p = &pixels[4 * (std::size_t(y) * size.x + x)];
        return glm::ivec3(p[0], p[1], p[2]);
    };
    EXPECT_EQ(rgb(2, 2), glm::ivec3(255, 0, 0));
    EXPECT_EQ(rgb(size.x - 3, size.y - 3), glm::ivec3(0, 0, 255));

    context->swap_buffers();
    context->poll_events();
    EXPECT_FALSE(context->should_close());
    check_gl("swapping");
}

}  // namespace
}  // namespace strata::gl
