// Lua source text for the scene-script writer and the node types' own lines in it (node_types.h):
// numbers as the shortest text that reads back to the same bits, string literals, and where a node's
// expression sits (its folder, for file names; its depth, for indentation).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace strata {

class Node;

namespace script {

// std::to_chars's shortest round-trip text (a float's own, which reads back through a double to the
// same float). −0 becomes "-0.0": Lua would read "-0" as the integer 0. Infinity (a far plane at
// infinity) is math.huge; NaN has no meaning to restore (std::runtime_error).
std::string number(double value);
std::string number(float value);

template <class Vec>
std::string numbers(const Vec& v) {
    std::string s = "{";
    for (int i = 0; i < Vec::length(); ++i) s += (i ? ", " : "") + number(v[i]);
    return s + "}";
}
inline std::string numbers(const glm::dquat& q) { return numbers(glm::dvec4(q.w, q.x, q.y, q.z)); }

// A Lua string literal: quotes, backslashes, line breaks and other control characters escaped; other
// bytes (UTF-8) as they are.
std::string string(std::string_view s);
inline std::string boolean(bool b) { return b ? "true" : "false"; }

// Throws std::runtime_error naming the node and its C++ type: "node 'x' (strata::Foo) `why`".
[[noreturn]] void cannot_write(const Node& node, const std::string& why);

// Where a node's constructor is written.
struct Place {
    std::filesystem::path folder;  // the script's folder, absolute
    int depth = 0;                 // nesting: 4 spaces a level

    // `path` relative to the script's folder, read back against wherever that folder is then.
    std::string file(const std::filesystem::path& path) const;
    std::string indent(int extra = 0) const { return std::string(4 * size_t(depth + extra), ' '); }
};

}  // namespace script
}  // namespace strata
