// Shader programs compiled from GLSL source strings: vertex + fragment, or compute. Failures throw
// GlError naming the program, the stage and the driver's log (which carries the line numbers).
#pragma once

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <functional>
#include <initializer_list>
#include <map>
#include <span>
#include <string>
#include <string_view>

#include "engine/gl/gl.h"
#include "engine/gl/object_name.h"

namespace strata::gl {

class Program {
public:
    Program() = default;  // no program
    // `name` identifies the program in error messages ("hlod", "resolve", ...).
    static Program graphics(std::string name, std::string_view vertex_source, std::string_view fragment_source);
    static Program compute(std::string name, std::string_view compute_source);

    void use() const { glUseProgram(id()); }

    // The uniform's location, looked up once and cached; -1 when the program has no such active
    // uniform (compilers drop unused ones; setting -1 is ignored, as GL does).
    GLint uniform_location(std::string_view uniform) const;

    // Uniform setters (glProgramUniform*: no need to use() the program first).
    void set(GLint location, float value) const { glProgramUniform1f(id(), location, value); }
    void set(GLint location, int value) const { glProgramUniform1i(id(), location, value); }
    void set(GLint location, unsigned value) const { glProgramUniform1ui(id(), location, value); }
    void set(GLint location, const glm::vec2& value) const;
    void set(GLint location, const glm::vec3& value) const;
    void set(GLint location, const glm::vec4& value) const;
    void set(GLint location, const glm::ivec2& value) const;
    void set(GLint location, const glm::mat3& value) const;
    void set(GLint location, const glm::mat4& value) const;
    void set(GLint location, std::span<const float> values) const;  // a float array uniform, from its first element
    void set(GLint location, std::span<const glm::mat4> values) const;  // a mat4 array uniform, likewise
    void set(GLint location, const glm::ivec3& value) const;
    template <class T>
    void set(std::string_view uniform, const T& value) const {
        set(uniform_location(uniform), value);
    }

    const std::string& name() const { return name_; }
    GLuint id() const { return program_.get(); }

private:
    struct Stage {
        GLenum type;
        std::string_view source;
    };
    Program(std::string name, std::initializer_list<Stage> stages);

    std::string name_;
    ObjectName<DeleteProgram> program_;
    mutable std::map<std::string, GLint, std::less<>> uniform_locations_;
};

}  // namespace strata::gl
