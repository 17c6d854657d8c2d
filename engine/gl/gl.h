// The one include for OpenGL in Strata (libepoxy loads the entry points), the backend's exception, and
// check_gl() for turning GL's sticky error flags into exceptions at the points we choose.
#pragma once

#include <epoxy/gl.h>

#include <stdexcept>
#include <string>

namespace strata::gl {

// Everything the GL backend throws: context creation, shader compilation, incomplete framebuffers,
// GL errors found by check_gl().
class GlError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// "GL_INVALID_OPERATION" for GL_INVALID_OPERATION; hex for codes GL does not define.
std::string gl_error_name(GLenum error);

// Throws GlError naming `what` and every pending GL error (GL can hold several flags at once).
// Does nothing when no error is pending.
void check_gl(const char* what);

}  // namespace strata::gl
