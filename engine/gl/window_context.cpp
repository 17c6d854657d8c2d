// Contexts in a GLFW window (the editor): OpenGL 4.5 core, vsync, the window's input for the caller.
#include "engine/gl/gl.h"  // epoxy before GLFW, and GLFW told not to include GL headers itself
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cstdlib>
#include <mutex>

#include "engine/gl/context.h"

namespace strata::gl {
namespace {

std::string glfw_error_description() {
    const char* description = nullptr;
    glfwGetError(&description);
    return description ? description : "no description from GLFW";
}

bool has_display() {
    for (const char* variable : {"DISPLAY", "WAYLAND_DISPLAY"})
        if (const char* value = std::getenv(variable); value && *value) return true;
    return false;
}

// GLFW is initialized once per process; counted so the last window to close terminates it.
class GlfwUsers {
public:
    static void acquire() {
        const std::lock_guard lock(mutex_);
        if (count_ == 0 && !glfwInit()) {
            if (!has_display())
                throw GlError("no display (DISPLAY is not set): use the headless renderer or run under Xvfb");
            throw GlError("GLFW cannot initialize: " + glfw_error_description());
        }
        ++count_;
    }
    static void release() {
        const std::lock_guard lock(mutex_);
        if (--count_ == 0) glfwTerminate();
    }

private:
    static inline std::mutex mutex_;
    static inline int count_ = 0;
};

class WindowContext final : public Context {
public:
    WindowContext() : Context("GLFW window") {}
    ~WindowContext() override;

    // Initializes GLFW, opens the window and makes its context current. Throws GlError; what was made
    // so far is released by the destructor.
    void open(const std::string& title, int width, int height);

    void make_current() override { glfwMakeContextCurrent(window_); }
    void swap_buffers() override { glfwSwapBuffers(window_); }
    bool should_close() const override { return glfwWindowShouldClose(window_); }
    void poll_events() override { glfwPollEvents(); }
    glm::ivec2 framebuffer_size() const override;
    GLFWwindow* window() const override { return window_; }

private:
    bool glfw_acquired_ = false;
    GLFWwindow* window_ = nullptr;
};

void WindowContext::open(const std::string& title, int width, int height) {
    GlfwUsers::acquire();
    glfw_acquired_ = true;
    glfwDefaultWindowHints();
    glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, gl_debug_requested() ? GLFW_TRUE : GLFW_FALSE);
    glfwWindowHint(GLFW_SRGB_CAPABLE, GLFW_TRUE);  // the viewer presents linear colour, encoded on the way
    window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (!window_)
        throw GlError("cannot create a window with an OpenGL 4.5 core context: " + glfw_error_description());
    make_current();
    glfwSwapInterval(1);
    finish_setup();
}

WindowContext::~WindowContext() {
    if (window_) glfwDestroyWindow(window_);
    if (glfw_acquired_) GlfwUsers::release();
}

glm::ivec2 WindowContext::framebuffer_size() const {
    glm::ivec2 size;
    glfwGetFramebufferSize(window_, &size.x, &size.y);
    return size;
}

}  // namespace

std::unique_ptr<Context> create_window_context(const std::string& title, int width, int height) {
    auto context = std::make_unique<WindowContext>();
    context->open(title, width, height);
    return context;
}

}  // namespace strata::gl
