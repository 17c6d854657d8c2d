// Program: compiling, linking with readable errors, and the uniform location cache.
#include "engine/gl/program.h"

#include <glm/gtc/type_ptr.hpp>

#include <vector>

namespace strata::gl {
namespace {

const char* stage_name(GLenum type) {
    switch (type) {
        case GL_VERTEX_SHADER: return "vertex";
        case GL_FRAGMENT_SHADER: return "fragment";
        case GL_COMPUTE_SHADER: return "compute";
    }
    return "unknown";
}

template <class GetLength, class GetLog>
std::string info_log(GLuint object, GetLength get_length, GetLog get_log) {
    GLint length = 0;
    get_length(object, GL_INFO_LOG_LENGTH, &length);
    std::string log(static_cast<std::size_t>(length), '\0');
    GLsizei written = 0;
    get_log(object, length, &written, log.data());
    log.resize(static_cast<std::size_t>(written));
    return log;
}

ObjectName<DeleteShader> compile(const std::string& program_name, GLenum type, std::string_view source) {
    ObjectName<DeleteShader> shader(glCreateShader(type));
    const char* text = source.data();
    const auto length = static_cast<GLint>(source.size());
    glShaderSource(shader.get(), 1, &text, &length);
    glCompileShader(shader.get());
    GLint compiled = GL_FALSE;
    glGetShaderiv(shader.get(), GL_COMPILE_STATUS, &compiled);
    if (!compiled)
        throw GlError("GL program '" + program_name + "': " + stage_name(type) + " shader does not compile:\n" +
                      info_log(shader.get(), glGetShaderiv, glGetShaderInfoLog));
    return shader;
}

}  // namespace

Program::Program(std::string name, std::initializer_list<Stage> stages)
    : name_(std::move(name)), program_(glCreateProgram()) {
    std::vector<ObjectName<DeleteShader>> shaders;
    for (const Stage& stage : stages) {
        shaders.push_back(compile(name_, stage.type, stage.source));
        glAttachShader(id(), shaders.back().get());
    }
    glLinkProgram(id());
    // The linked program keeps the code; the shader objects are no longer needed.
    for (const auto& shader : shaders) glDetachShader(id(), shader.get());
    GLint linked = GL_FALSE;
    glGetProgramiv(id(), GL_LINK_STATUS, &linked);
    if (!linked)
        throw GlError("GL program '" + name_ + "' does not link:\n" +
                      info_log(id(), glGetProgramiv, glGetProgramInfoLog));
}

Program Program::graphics(std::string name, std::string_view vertex_source, std::string_view fragment_source) {
    return Program(std::move(name), {{GL_VERTEX_SHADER, vertex_source}, {GL_FRAGMENT_SHADER, fragment_source}});
}

Program Program::compute(std::string name, std::string_view compute_source) {
    return Program(std::move(name), {{GL_COMPUTE_SHADER, compute_source}});
}

GLint Program::uniform_location(std::string_view uniform) const {
    if (auto found = uniform_locations_.find(uniform); found != uniform_locations_.end()) return found->second;
    const std::string key(uniform);
    const GLint location = glGetUniformLocation(id(), key.c_str());
    uniform_locations_.emplace(key, location);
    return location;
}

void Program::set(GLint location, const glm::vec2& value) const {
    glProgramUniform2fv(id(), location, 1, glm::value_ptr(value));
}
void Program::set(GLint location, const glm::vec3& value) const {
    glProgramUniform3fv(id(), location, 1, glm::value_ptr(value));
}
void Program::set(GLint location, const glm::vec4& value) const {
    glProgramUniform4fv(id(), location, 1, glm::value_ptr(value));
}
void Program::set(GLint location, const glm::ivec2& value) const {
    glProgramUniform2iv(id(), location, 1, glm::value_ptr(value));
}
void Program::set(GLint location, const glm::mat3& value) const {
    glProgramUniformMatrix3fv(id(), location, 1, GL_FALSE, glm::value_ptr(value));
}
void Program::set(GLint location, const glm::mat4& value) const {
    glProgramUniformMatrix4fv(id(), location, 1, GL_FALSE, glm::value_ptr(value));
}
void Program::set(GLint location, std::span<const glm::mat4> values) const {
    glProgramUniformMatrix4fv(id(), location, GLsizei(values.size()), GL_FALSE, glm::value_ptr(values.front()));
}
void Program::set(GLint location, std::span<const float> values) const {
    glProgramUniform1fv(id(), location, GLsizei(values.size()), values.data());
}

void Program::set(GLint location, const glm::ivec3& value) const { glProgramUniform3i(id(), location, value.x, value.y, value.z); }

}  // namespace strata::gl
