// Ownership of one OpenGL object name (buffer, texture, program, ...): deleted with the object, moved
// but never copied, 0 meaning "none". The GL resource classes are built on it.
#pragma once

#include <utility>

#include "engine/gl/gl.h"

namespace strata::gl {

template <class Delete>
class ObjectName {
public:
    ObjectName() = default;
    explicit ObjectName(GLuint name) : name_(name) {}
    ObjectName(ObjectName&& other) noexcept : name_(std::exchange(other.name_, 0)) {}
    ObjectName& operator=(ObjectName&& other) noexcept {
        if (this != &other) {
            reset();
            name_ = std::exchange(other.name_, 0);
        }
        return *this;
    }
    ~ObjectName() { reset(); }

    GLuint get() const { return name_; }
    explicit operator bool() const { return name_ != 0; }

private:
    void reset() {
        if (name_ != 0) Delete{}(name_);
        name_ = 0;
    }
    GLuint name_ = 0;
};

struct DeleteBuffer {
    void operator()(GLuint name) const { glDeleteBuffers(1, &name); }
};
struct DeleteTexture {
    void operator()(GLuint name) const { glDeleteTextures(1, &name); }
};
struct DeleteFramebuffer {
    void operator()(GLuint name) const { glDeleteFramebuffers(1, &name); }
};
struct DeleteVertexArray {
    void operator()(GLuint name) const { glDeleteVertexArrays(1, &name); }
};
struct DeleteShader {
    void operator()(GLuint name) const { glDeleteShader(name); }
};
struct DeleteProgram {
    void operator()(GLuint name) const { glDeleteProgram(name); }
};

}  // namespace strata::gl
