#include "scripting/script_text.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cxxabi.h>
#include <stdexcept>
#include <typeinfo>

#include "engine/scene/node.h"

namespace strata::script {

namespace {

template <class T>
std::string shortest(T value) {
    if (std::isnan(value)) throw std::runtime_error("NaN cannot be written");
    if (std::isinf(value)) return value > 0 ? "math.huge" : "-math.huge";
    char text[64];
    const std::string s(text, std::to_chars(text, text + sizeof text, value).ptr);
    return s == "-0" ? "-0.0" : s;
}

std::string type_of(const Node& node) {
    const char* mangled = typeid(node).name();
    int status = 0;
    char* demangled = abi::__cxa_demangle(mangled, nullptr, nullptr, &status);
    std::string name = status == 0 ? demangled : mangled;
    std::free(demangled);
    return name;
}

}  // namespace

std::string number(double value) { return shortest(value); }
std::string number(float value) { return shortest(value); }

std::string string(std::string_view s) {
    std::string out = "\"";
    for (const unsigned char c : s) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += char(c);
        } else if (c == '\n') {
            out += "\\n";
        } else if (c < 0x20 || c == 0x7f) {
            char escape[8];
            std::snprintf(escape, sizeof escape, "\\%03d", c);  // three digits: a digit after it stays itself
            out += escape;
        } else {
            out += char(c);
        }
    }
    return out + "\"";
}

void cannot_write(const Node& node, const std::string& why) {
    throw std::runtime_error("node '" + node.name() + "' (" + type_of(node) + ") " + why);
}

std::string Place::file(const std::filesystem::path& path) const {
    return "here .. " + string(std::filesystem::relative(std::filesystem::absolute(path), folder).generic_string());
}

}  // namespace strata::script
