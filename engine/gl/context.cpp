// What every Context does once current: driver strings, the 4.5 check, the optional debug printer.
#include "engine/gl/context.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "engine/gl/gl.h"

namespace strata::gl {
namespace {

std::string gl_string(GLenum name) {
    const auto* text = reinterpret_cast<const char*>(glGetString(name));
    return text ? text : "";
}

const char* debug_severity_name(GLenum severity) {
    switch (severity) {
        case GL_DEBUG_SEVERITY_HIGH: return "high";
        case GL_DEBUG_SEVERITY_MEDIUM: return "medium";
        case GL_DEBUG_SEVERITY_LOW: return "low";
    }
    return "note";
}

void GLAPIENTRY print_debug_message(GLenum /*source*/, GLenum /*type*/, GLuint id, GLenum severity,
                                    GLsizei /*length*/, const GLchar* message, const void* /*user*/) {
    std::fprintf(stderr, "[GL %s %u] %s\n", debug_severity_name(severity), id, message);
}

void install_debug_printer() {
    glEnable(GL_DEBUG_OUTPUT);
    // Synchronous, so a message is printed inside the call that caused it (breakpoints, backtraces).
    glEnable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
    glDebugMessageCallback(print_debug_message, nullptr);
    // Notifications (buffer placement, shader recompiles) drown the warnings that matter.
    glDebugMessageControl(GL_DONT_CARE, GL_DONT_CARE, GL_DEBUG_SEVERITY_NOTIFICATION, 0, nullptr, GL_FALSE);
}

}  // namespace

bool gl_debug_requested() {
    const char* value = std::getenv("STRATA_GL_DEBUG");
    return value && std::strcmp(value, "1") == 0;
}

void Context::finish_setup() {
    renderer_ = gl_string(GL_RENDERER);
    version_ = gl_string(GL_VERSION);
    const int version = epoxy_gl_version();  // 10 * major + minor
    if (version < 45)
        throw GlError("got OpenGL " + std::to_string(version / 10) + "." + std::to_string(version % 10) +
                      " (" + version_ + ", " + renderer_ + "), Strata needs 4.5 core");
    if (gl_debug_requested()) install_debug_printer();
}

}  // namespace strata::gl
