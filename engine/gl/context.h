// An OpenGL 4.5 core context: headless through EGL (offline rendering, tests, servers) or in a GLFW
// window (the editor). Both create the context, make it current on the calling thread and check the
// version before returning.
#pragma once

#include <glm/vec2.hpp>

#include <memory>
#include <string>

struct GLFWwindow;

namespace strata::gl {

class Context {
public:
    virtual ~Context() = default;
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    // Makes this context current on the calling thread (a context is current on one thread at a time).
    virtual void make_current() = 0;

    // Driver strings, recorded when the context was created: "llvmpipe (LLVM 15.0.6, 256 bits)",
    // "4.5 (Core Profile) Mesa 22.3.6".
    const std::string& renderer() const { return renderer_; }
    const std::string& version() const { return version_; }
    // How the context was made: "EGL surfaceless (Mesa)", "EGL device 0", "GLFW window", ...
    const std::string& platform() const { return platform_; }

    // Window operations. A headless context has no default framebuffer: swapping and polling do
    // nothing, it never asks to close, its framebuffer size is 0×0 and its window is null.
    virtual void swap_buffers() {}
    virtual bool should_close() const { return false; }
    virtual void poll_events() {}
    virtual glm::ivec2 framebuffer_size() const { return {0, 0}; }
    virtual GLFWwindow* window() const { return nullptr; }

protected:
    explicit Context(std::string platform) : platform_(std::move(platform)) {}
    // With this context current: loads the driver strings, throws GlError below OpenGL 4.5, and
    // installs the debug-message printer when STRATA_GL_DEBUG=1.
    void finish_setup();

private:
    std::string platform_;
    std::string renderer_;
    std::string version_;
};

// True when STRATA_GL_DEBUG=1: contexts are then created with the debug flag and print the driver's
// debug messages to stderr.
bool gl_debug_requested();

// An EGL context with no window, current on return. Tries, in order: Mesa's surfaceless platform
// (EGL_MESA_platform_surfaceless), the device platform (EGL_EXT_platform_device: each device until one
// works; NVIDIA's headless path), then the default display with a 1×1 pbuffer.
// STRATA_EGL_PLATFORM=surfaceless|device|default tries only that one. Throws GlError saying what each
// platform answered (EGL error names, or the OpenGL version obtained when it is below 4.5).
std::unique_ptr<Context> create_headless_context();

// A GLFW window with an OpenGL 4.5 core context, current on return, vsync on. Throws GlError when
// there is no display ("no display (DISPLAY is not set): ...") or GLFW cannot make the window or
// context (with GLFW's own description).
std::unique_ptr<Context> create_window_context(const std::string& title, int width, int height);

}  // namespace strata::gl
