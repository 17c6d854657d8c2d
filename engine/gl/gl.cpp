// GL error names and check_gl().
#include "engine/gl/gl.h"

#include <cstdio>

namespace strata::gl {

std::string gl_error_name(GLenum error) {
    switch (error) {
        case GL_NO_ERROR: return "GL_NO_ERROR";
        case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
        case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
        case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
        case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
        case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
        case GL_STACK_UNDERFLOW: return "GL_STACK_UNDERFLOW";
        case GL_STACK_OVERFLOW: return "GL_STACK_OVERFLOW";
        case GL_CONTEXT_LOST: return "GL_CONTEXT_LOST";
    }
    char hex[32];
    std::snprintf(hex, sizeof hex, "GL error 0x%04X", error);
    return hex;
}

void check_gl(const char* what) {
    std::string errors;
    // A lost context reports GL_CONTEXT_LOST on every call: stop after a few rather than spin.
    for (int i = 0; i < 8; ++i) {
        const GLenum error = glGetError();
        if (error == GL_NO_ERROR) break;
        errors += (errors.empty() ? "" : ", ") + gl_error_name(error);
    }
    if (!errors.empty()) throw GlError("OpenGL error after " + std::string(what) + ": " + errors);
}

}  // namespace strata::gl
