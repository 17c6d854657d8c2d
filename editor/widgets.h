// Small pieces the editor's panels share.
#pragma once

#include <exception>
#include <string>

#include "scripting/inspector.h"

namespace strata {

// A node type's inspector fields (scripting/node_types.h) as Dear ImGui widgets.
class ImGuiInspector : public Inspector {
public:
    bool slider(const char* label, double& value, double lo, double hi, const char* format) override;
    bool number(const char* label, double& value, const char* format) override;
    bool vector(const char* label, glm::dvec3& value, const char* format) override;
    bool toggle(const char* label, bool& value) override;
    bool choice(const char* label, int& value, std::span<const char* const> options) override;
    void text(const std::string& line) override;
    void note(const std::string& line) override;
};

// A text field for a file name (`hint` while empty) filling the row but for `button` beside it;
// true when the button was pressed.
bool file_field(const char* id, const char* hint, std::string& file, const char* button);

// Runs `action` and returns `done`, or the error's message when it throws: the line a panel shows
// under the button that started it.
template <typename Action>
std::string outcome(Action&& action, std::string done) {
    try {
        action();
        return done;
    } catch (const std::exception& e) {
        return e.what();
    }
}

}  // namespace strata
