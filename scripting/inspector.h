// What a node type's inspector draws with: a few kinds of field, each returning true when the user
// changed its value. The editor implements it with Dear ImGui; the node types (node_types.h) say which
// fields they have, so a type's inspector is declared with the rest of it, and tests can drive one.
#pragma once

#include <span>
#include <string>

#include <glm/glm.hpp>

namespace strata {

class Inspector {
public:
    virtual ~Inspector() = default;
    // A number on a logarithmic slider within [lo, hi]; `format` is printf's, for a double.
    virtual bool slider(const char* label, double& value, double lo, double hi, const char* format) = 0;
    // A number typed in.
    virtual bool number(const char* label, double& value, const char* format) = 0;
    // Three numbers typed in.
    virtual bool vector(const char* label, glm::dvec3& value, const char* format) = 0;
    virtual bool toggle(const char* label, bool& value) = 0;
    // One of `options`, its index in `value`.
    virtual bool choice(const char* label, int& value, std::span<const char* const> options) = 0;
    virtual void text(const std::string& line) = 0;
    // A line in grey: a remark on the fields around it.
    virtual void note(const std::string& line) = 0;
};

}  // namespace strata
