#include "engine/render/present.h"

namespace strata {

namespace {

// A multisampled frame resolves only into a target of its own size: resolve into a single-sample
// copy first when the window is another size, then scale that.
void blit_resolved(gl::Framebuffer& frame, glm::ivec2 size) {
    GLuint copy = 0, color = 0;
    glCreateRenderbuffers(1, &color);
    glNamedRenderbufferStorage(color, GL_RGBA16F, frame.width(), frame.height());
    glCreateFramebuffers(1, &copy);
    glNamedFramebufferRenderbuffer(copy, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color);
    glBlitNamedFramebuffer(frame.id(), copy, 0, 0, frame.width(), frame.height(), 0, 0, frame.width(), frame.height(),
                           GL_COLOR_BUFFER_BIT, GL_NEAREST);
    glBlitNamedFramebuffer(copy, 0, 0, 0, frame.width(), frame.height(), 0, 0, size.x, size.y, GL_COLOR_BUFFER_BIT,
                           GL_LINEAR);
    glDeleteFramebuffers(1, &copy);
    glDeleteRenderbuffers(1, &color);
}

}  // namespace

void present(gl::Framebuffer& frame, gl::Context& window) {
    blit_to_window(frame, window);
    window.swap_buffers();
}

void blit_to_window(gl::Framebuffer& frame, gl::Context& window) {
    const glm::ivec2 size = window.framebuffer_size();
    glEnable(GL_FRAMEBUFFER_SRGB);
    glNamedFramebufferReadBuffer(frame.id(), GL_COLOR_ATTACHMENT0);
    if (frame.samples() > 1 && (size.x != frame.width() || size.y != frame.height()))
        blit_resolved(frame, size);
    else
        glBlitNamedFramebuffer(frame.id(), 0, 0, 0, frame.width(), frame.height(), 0, 0, size.x, size.y,
                               GL_COLOR_BUFFER_BIT, frame.samples() > 1 ? GL_NEAREST : GL_LINEAR);
    glDisable(GL_FRAMEBUFFER_SRGB);
    gl::check_gl("showing a frame in the window");
}

}  // namespace strata
