// Vertex array objects. Core profile draws nothing without one bound, even when the vertex shader
// takes everything from storage buffers by gl_VertexID: bind an empty one for attribute-less drawing.
#pragma once

#include "engine/gl/gl.h"
#include "engine/gl/object_name.h"

namespace strata::gl {

class VertexArray {
public:
    VertexArray() = default;  // no vertex array
    static VertexArray create() {
        GLuint name = 0;
        glCreateVertexArrays(1, &name);
        return VertexArray(name);
    }

    void bind() const { glBindVertexArray(id()); }
    GLuint id() const { return name_.get(); }

private:
    explicit VertexArray(GLuint name) : name_(name) {}
    ObjectName<DeleteVertexArray> name_;
};

}  // namespace strata::gl
